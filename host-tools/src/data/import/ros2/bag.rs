//! A bag being read: the topics the storage declares, their messages
//! decoded and counted, then the choice of topics, the clock and the rows
//! in this project's frames and units ([`Bag::finish`]).

use std::collections::BTreeMap;

use super::super::rules::{self, Kind, Series};
use super::super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use super::{check_definition, enu_flu_to_ned_frd_euler_deg, flu_to_frd, Definition, MsgType, Ros2Error, Sample, IMU, MAGNETIC_FIELD, NAV_SAT_FIX};
use crate::data::table::col;

/// The first bytes of a zstd frame (rosbag2's per-message compression).
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];

#[derive(Debug)]
struct TopicState {
    name: String,
    type_name: String,
    msg_type: Option<MsgType>,
    /// Why its messages are not read (a definition that differs, not CDR).
    refused: Option<(&'static str, String)>,
    messages: usize,
    samples: Vec<Sample>,
    skipped: BTreeMap<&'static str, usize>,
}

/// A bag being read: topics declared by the storage, messages fed to it in
/// the bag's order, then [`Bag::finish`].
#[derive(Debug)]
pub struct Bag {
    format: Format,
    topics: Vec<TopicState>,
    skipped: BTreeMap<String, usize>,
    notes: Vec<String>,
}

impl Bag {
    /// An empty bag of `format` ([`Format::Mcap`] or [`Format::Sqlite3`]).
    pub fn new(format: Format) -> Self {
        Self { format, topics: Vec::new(), skipped: BTreeMap::new(), notes: Vec::new() }
    }

    /// Declares a topic: its name, type, serialization (`cdr`) and stored
    /// definition; the index [`Bag::message`] takes.
    pub fn topic(&mut self, name: &str, type_name: &str, serialization: &str, definition: Option<&Definition>) -> usize {
        let msg_type = MsgType::from_name(type_name);
        let mut refused = None;
        if let Some(t) = msg_type {
            if !serialization.eq_ignore_ascii_case("cdr") {
                refused = Some(("not_cdr", format!("serialized as {serialization:?}, not CDR")));
            } else {
                match definition {
                    Some(d) if d.encoding == "ros2msg" => {
                        if let Err(e) = check_definition(t.name(), &d.text) {
                            refused = Some(("definition_differs", format!("the bag's definition is not the layout read: {e}")));
                        }
                    }
                    Some(d) => self.note(format!("{name}: definition in {:?}, not checked: decoded as {}", d.encoding, t.name())),
                    None => self.note(format!("{name}: no definition stored: decoded as {} by its type's name", t.name())),
                }
            }
        }
        self.topics.push(TopicState { name: name.into(), type_name: type_name.into(), msg_type, refused, messages: 0, samples: Vec::new(), skipped: BTreeMap::new() });
        self.topics.len() - 1
    }

    /// Whether the messages of topic `topic` are decoded (of a type read and
    /// not refused): a storage may leave the others' data unread.
    pub fn decodes(&self, topic: usize) -> bool {
        self.topics.get(topic).is_some_and(|t| t.msg_type.is_some() && t.refused.is_none())
    }

    /// One message of topic `topic` (from [`Bag::topic`]), received at
    /// `receive_ns`; decoded when its type is read, counted always.
    pub fn message(&mut self, topic: usize, receive_ns: i64, data: &[u8]) {
        let Some(t) = self.topics.get_mut(topic) else {
            *self.skipped.entry("message_of_unknown_topic".into()).or_default() += 1;
            return;
        };
        t.messages += 1;
        let Some(msg_type) = t.msg_type else { return };
        if let Some((kind, _)) = &t.refused {
            *t.skipped.entry(kind).or_default() += 1;
            return;
        }
        if data.starts_with(&ZSTD_MAGIC) {
            *t.skipped.entry("zstd_compressed_message").or_default() += 1;
            let note = "messages compressed one by one (rosbag2's message compression, zstd) are not read: decompress the bag first (ros2 bag convert)".to_string();
            if !self.notes.contains(&note) {
                self.notes.push(note);
            }
            return;
        }
        match msg_type.decode(data, receive_ns) {
            Ok(Some(s)) => t.samples.push(s),
            Ok(None) => *t.skipped.entry("navsatfix_without_fix").or_default() += 1,
            Err(e) => *t.skipped.entry(e.kind()).or_default() += 1,
        }
    }

    /// Counts `n` refusals of `kind` by the storage (a corrupt chunk, a
    /// truncated tail).
    pub fn skip(&mut self, kind: &str, n: usize) {
        if n > 0 {
            *self.skipped.entry(kind.to_string()).or_default() += n;
        }
    }

    /// A note from the storage.
    pub fn note(&mut self, note: impl Into<String>) {
        let note = note.into();
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    /// Topics of `t`, the busiest first (ties: by name).
    fn of_type(&self, t: MsgType, filter: impl Fn(&TopicState) -> bool) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.topics.len()).filter(|&i| self.topics[i].msg_type == Some(t) && filter(&self.topics[i])).collect();
        idx.sort_by(|&a, &b| self.topics[b].messages.cmp(&self.topics[a].messages).then_with(|| self.topics[a].name.cmp(&self.topics[b].name)));
        idx
    }

    /// The busiest usable topic of a kind, with a note when there were
    /// several.
    fn pick(&mut self, what: &str, candidates: Vec<usize>) -> Option<usize> {
        let usable: Vec<usize> = candidates.iter().copied().filter(|&i| self.topics[i].refused.is_none()).collect();
        let chosen = usable.first().copied();
        if let Some(c) = chosen {
            if candidates.len() > 1 {
                let list = candidates.iter().map(|&i| format!("{} ({})", self.topics[i].name, self.topics[i].messages)).collect::<Vec<_>>().join(", ");
                self.note(format!("{what}: {} topics ({list}); {} taken (the most messages)", candidates.len(), self.topics[c].name));
            }
        }
        chosen
    }

    /// The import: the magnetometer topic's samples as rows, the other
    /// topics' carried to their times ([`rules::Series`]), in this project's
    /// frames and units; `wrap` makes the format's error from a
    /// [`Ros2Error`].
    pub fn finish(mut self, opts: &ImportOptions, wrap: impl Fn(Ros2Error) -> ImportError) -> Result<Imported, ImportError> {
        let all_topics: Vec<String> = self.topics.iter().map(|t| format!("{} ({})", t.name, t.type_name)).collect();
        let mags = self.of_type(MsgType::MagneticField, |_| true);
        let mag = match &opts.topic {
            Some(wanted) => {
                let Some(&i) = mags.iter().find(|&&i| self.topics[i].name == *wanted) else {
                    return Err(wrap(Ros2Error::NoTopic { wanted: wanted.clone(), found: mags.iter().map(|&i| self.topics[i].name.clone()).collect() }));
                };
                if mags.len() > 1 {
                    let list = mags.iter().map(|&i| self.topics[i].name.clone()).collect::<Vec<_>>().join(", ");
                    self.note(format!("magnetometer: {} of {list} (--topic)", self.topics[i].name));
                }
                i
            }
            None => {
                let Some(&first) = mags.first() else { return Err(wrap(Ros2Error::NoMagnetometer { topics: all_topics })) };
                self.pick("magnetometer", mags.clone()).unwrap_or(first)
            }
        };
        let m = &self.topics[mag];
        if let Some((_, detail)) = &m.refused {
            return Err(wrap(Ros2Error::Definition { topic: m.name.clone(), type_name: m.type_name.clone(), detail: detail.clone() }));
        }
        if m.samples.is_empty() {
            let skipped = m.skipped.iter().map(|(k, v)| (k.to_string(), *v)).collect();
            return Err(wrap(Ros2Error::NoSamples { topic: m.name.clone(), messages: m.messages, skipped }));
        }
        let heading_named = |t: &TopicState| t.name.to_ascii_lowercase().contains("heading");
        let imu_candidates = self.of_type(MsgType::Imu, |t| !heading_named(t));
        let imu = self.pick("attitude (sensor_msgs/msg/Imu)", imu_candidates);
        let fix_candidates = self.of_type(MsgType::NavSatFix, |_| true);
        let fix = self.pick("position (sensor_msgs/msg/NavSatFix)", fix_candidates);
        let mut heading_candidates = self.of_type(MsgType::QuaternionStamped, heading_named);
        heading_candidates.extend(self.of_type(MsgType::Imu, heading_named));
        let heading = self.pick("heading reference (a topic named *heading*)", heading_candidates);

        // The clock: header stamps, unless the magnetometer's are all zero
        // (then the receive time for every topic); another topic whose
        // stamps are all zero on its receive time.
        let has_stamps = |t: &TopicState| t.samples.iter().any(|s| s.stamp_ns != 0);
        let stamped = has_stamps(&self.topics[mag]);
        let by_stamp: Vec<bool> = self.topics.iter().map(|t| stamped && has_stamps(t)).collect();
        let time = |i: usize, s: &Sample| if by_stamp.get(i) == Some(&true) { s.stamp_ns } else { s.receive_ns };
        let mag_name = self.topics[mag].name.clone();
        let t0_ns = self.topics[mag].samples.iter().map(|s| time(mag, s)).min().unwrap_or(0);
        // i128: a hostile receive time may be anywhere on i64.
        let t_of = |ns: i64| (i128::from(ns) - i128::from(t0_ns)) as f64 / 1e9;
        let clock = if stamped {
            format!("s since the first {mag_name} header.stamp ({}.{:09} s since the UNIX epoch); every topic on its header.stamp", t0_ns.div_euclid(1_000_000_000), t0_ns.rem_euclid(1_000_000_000))
        } else {
            format!("s since the first {mag_name} message received ({}.{:09} s since the UNIX epoch): the bag's receive time for every topic", t0_ns.div_euclid(1_000_000_000), t0_ns.rem_euclid(1_000_000_000))
        };
        if !stamped {
            self.note(format!("{mag_name}: every header.stamp is zero: the bag's receive time is the clock for every topic"));
        }
        for i in [imu, fix, heading].into_iter().flatten() {
            if stamped && !by_stamp[i] && !self.topics[i].samples.is_empty() {
                let name = self.topics[i].name.clone();
                self.note(format!("{name}: every header.stamp is zero: its receive time used (later than the sample by the transport's delay)"));
            }
        }

        let mut non_finite = 0;
        let mut t_s = Vec::new();
        let mut field_nt: [Vec<f64>; 3] = Default::default();
        for s in &self.topics[mag].samples {
            let f = flu_to_frd([s.v[0], s.v[1], s.v[2]]).map(|v| v * rules::NT_PER_TESLA);
            if f.iter().any(|v| !v.is_finite()) {
                non_finite += 1;
                continue;
            }
            t_s.push(t_of(time(mag, s)));
            for k in 0..3 {
                field_nt[k].push(f[k]);
            }
        }
        let mut att = Series::new([Kind::Angle180, Kind::Linear, Kind::Heading360]);
        let mut gyro = Series::new([Kind::Linear; 3]);
        if let Some(i) = imu {
            for s in &self.topics[i].samples {
                if let Some(e) = enu_flu_to_ned_frd_euler_deg([s.v[0], s.v[1], s.v[2], s.v[3]]) {
                    att.push(t_of(time(i, s)), e);
                }
                let g = flu_to_frd([s.v[4], s.v[5], s.v[6]]);
                if g.iter().all(|v| v.is_finite()) {
                    gyro.push(t_of(time(i, s)), g);
                }
            }
        }
        let mut pos = Series::new([Kind::Linear; 2]);
        if let Some(i) = fix {
            for s in &self.topics[i].samples {
                pos.push(t_of(time(i, s)), [s.v[0], s.v[1]]);
            }
        }
        let mut hdg = Series::new([Kind::Heading360]);
        if let Some(i) = heading {
            for s in &self.topics[i].samples {
                if let Some(e) = enu_flu_to_ned_frd_euler_deg([s.v[0], s.v[1], s.v[2], s.v[3]]) {
                    hdg.push(t_of(time(i, s)), [e[2]]);
                }
            }
        }
        let carried = |series_at: &dyn Fn(f64) -> Option<Vec<f64>>, k: usize| -> Vec<f64> { t_s.iter().map(|&t| series_at(t).and_then(|v| v.get(k).copied()).unwrap_or(f64::NAN)).collect() };
        let age = opts.max_age_s;
        let att_at = |t: f64| att.at(t, age).map(|v| v.to_vec());
        let gyro_at = |t: f64| gyro.at(t, age).map(|v| v.to_vec());
        let pos_at = |t: f64| pos.at(t, age).map(|v| v.to_vec());
        let hdg_at = |t: f64| hdg.at(t, age).map(|v| v.to_vec());
        let columns = [
            (col::ROLL_DEG, carried(&att_at, 0)),
            (col::PITCH_DEG, carried(&att_at, 1)),
            (col::AHRS_YAW_DEG, carried(&att_at, 2)),
            (col::GYRO[0], carried(&gyro_at, 0)),
            (col::GYRO[1], carried(&gyro_at, 1)),
            (col::GYRO[2], carried(&gyro_at, 2)),
            (col::LAT_DEG, carried(&pos_at, 0)),
            (col::LON_DEG, carried(&pos_at, 1)),
            (col::REF_HEADING_DEG, carried(&hdg_at, 0)),
        ];
        let out_of_order = att.out_of_order + gyro.out_of_order + pos.out_of_order + hdg.out_of_order;

        let mut b = Builder::new(self.format, t_s, clock);
        b.report.field_unit = Some("nT".into());
        let frd = "FLU → FRD: (x, −y, −z)";
        for (k, name) in col::MAG.into_iter().enumerate() {
            b.column(name, std::mem::take(&mut field_nt[k]), format!("{MAGNETIC_FIELD} {mag_name}: magnetic_field (T × 1e9 → nT), {frd}"), Role::Compass)?;
        }
        let topic_name = |i: Option<usize>| i.map(|i| self.topics[i].name.clone()).unwrap_or_default();
        let (imu_name, fix_name, hdg_name) = (topic_name(imu), topic_name(fix), topic_name(heading));
        let hdg_type = heading.map(|i| self.topics[i].type_name.clone()).unwrap_or_default();
        for (name, values) in columns {
            let (from, role) = match name {
                col::ROLL_DEG | col::PITCH_DEG => (format!("{IMU} {imu_name}: orientation (ENU/FLU → NED/FRD, Z-Y-X)"), Role::Sensor),
                col::AHRS_YAW_DEG => (format!("{IMU} {imu_name}: orientation's heading (90° − the ENU yaw): the vehicle's own estimate"), Role::OwnEstimate),
                col::LAT_DEG | col::LON_DEG => (format!("{NAV_SAT_FIX} {fix_name}: latitude, longitude (status ≥ 0)"), Role::Sensor),
                col::REF_HEADING_DEG => (format!("{hdg_type} {hdg_name}: heading (90° − the ENU yaw), an independent heading reference (the topic's name)"), Role::Reference),
                _ => (format!("{IMU} {imu_name}: angular_velocity (rad/s), {frd}"), Role::Sensor),
            };
            b.column(name, values, from, role)?;
        }
        for t in &self.topics {
            *b.report.messages.entry(t.name.clone()).or_default() += t.messages;
            for (kind, n) in &t.skipped {
                b.skip(&format!("{kind}: {}", t.name), *n);
            }
            if let Some((_, why)) = &t.refused {
                b.note(format!("{}: not read: {why}", t.name));
            }
        }
        for (kind, n) in &self.skipped {
            b.skip(kind, *n);
        }
        b.skip(&format!("non_finite_field: {mag_name}"), non_finite);
        b.skip("sample_older_than_the_last (other topics)", out_of_order);
        for n in std::mem::take(&mut self.notes) {
            b.note(n);
        }
        b.note("frames: ROS's FLU body and ENU world (REP 103) converted to FRD and NED: field and rates (x, −y, −z); roll kept, pitch negated, heading = 90° − the ENU yaw".to_string());
        for i in [Some(mag), imu, heading].into_iter().flatten() {
            if self.topics[i].samples.iter().any(|s| s.ned_frame_id) {
                b.note(format!(
                    "{}: a header.frame_id ends in _ned or _frd: a driver may publish in NED/FRD already; converted from ENU/FLU (REP 103) all the same: check the signs",
                    self.topics[i].name
                ));
            }
        }
        if heading.is_none() {
            b.note("no heading reference: no QuaternionStamped or Imu topic named *heading* (a GNSS compass's); ahrs_yaw_deg is the vehicle's own estimate, not a reference".to_string());
        }
        b.finish()
    }
}

//! The check of the message definitions a bag stores (`ros2msg`) against
//! the layouts [`super::cdr`] decodes, field by field.

/// The layouts read: each type's fields (type, name) in order, types by
/// their last path element.
const LAYOUTS: &[(&str, &[(&str, &str)])] = &[
    ("MagneticField", &[("Header", "header"), ("Vector3", "magnetic_field"), ("float64[9]", "magnetic_field_covariance")]),
    (
        "Imu",
        &[
            ("Header", "header"),
            ("Quaternion", "orientation"),
            ("float64[9]", "orientation_covariance"),
            ("Vector3", "angular_velocity"),
            ("float64[9]", "angular_velocity_covariance"),
            ("Vector3", "linear_acceleration"),
            ("float64[9]", "linear_acceleration_covariance"),
        ],
    ),
    (
        "NavSatFix",
        &[
            ("Header", "header"),
            ("NavSatStatus", "status"),
            ("float64", "latitude"),
            ("float64", "longitude"),
            ("float64", "altitude"),
            ("float64[9]", "position_covariance"),
            ("uint8", "position_covariance_type"),
        ],
    ),
    ("QuaternionStamped", &[("Header", "header"), ("Quaternion", "quaternion")]),
    ("Header", &[("Time", "stamp"), ("string", "frame_id")]),
    ("Time", &[("int32", "sec"), ("uint32", "nanosec")]),
    ("Vector3", &[("float64", "x"), ("float64", "y"), ("float64", "z")]),
    ("Quaternion", &[("float64", "x"), ("float64", "y"), ("float64", "z"), ("float64", "w")]),
    ("NavSatStatus", &[("int8", "status"), ("uint16", "service")]),
];

fn short_type(t: &str) -> &str {
    t.rsplit('/').next().unwrap_or(t)
}

/// The fields (type, name) of one `.msg` section: comments, blank lines and
/// constants (`TYPE NAME=VALUE`) left out, default values ignored.
fn msg_fields(section: &str) -> Vec<(String, String)> {
    section
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty() && !l.contains('='))
        .filter_map(|l| {
            let mut it = l.split_whitespace();
            Some((short_type(it.next()?).to_string(), it.next()?.to_string()))
        })
        .collect()
}

/// Checks a `ros2msg` definition of `type_name` (the message's own text,
/// then each included type after a line of `=` and `MSG: pkg/Type`) against
/// the layout read: `Err` says the first difference.
pub fn check_definition(type_name: &str, text: &str) -> Result<(), String> {
    let mut sections: Vec<(String, &str)> = Vec::new();
    let mut name = short_type(type_name).to_string();
    let mut rest = text;
    loop {
        let (body, next) = match rest.find("\n====") {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        sections.push((name.clone(), body));
        let Some(next) = next else { break };
        // Past the line of '=' to the "MSG: pkg/Type" line.
        let after_rule = next.split_once('\n').map_or("", |(_, r)| r);
        let (msg_line, body_rest) = after_rule.split_once('\n').unwrap_or((after_rule, ""));
        name = match msg_line.trim().strip_prefix("MSG:") {
            Some(t) => short_type(t.trim()).to_string(),
            None => return Err(format!("an included definition without its MSG: line ({:?})", msg_line.trim())),
        };
        rest = body_rest;
    }
    for (name, body) in sections {
        let Some((_, want)) = LAYOUTS.iter().find(|(n, _)| *n == name) else { continue };
        let got = msg_fields(body);
        let want: Vec<(String, String)> = want.iter().map(|(t, n)| (t.to_string(), n.to_string())).collect();
        if got != want {
            let show = |f: &[(String, String)]| f.iter().map(|(t, n)| format!("{t} {n}")).collect::<Vec<_>>().join("; ");
            return Err(format!("{name}: fields [{}], read as [{}]", show(&got), show(&want)));
        }
    }
    Ok(())
}

/// A type's definition as a bag stores it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Definition {
    /// `ros2msg`, `ros2idl`, or what the bag says.
    pub encoding: String,
    /// The text.
    pub text: String,
}

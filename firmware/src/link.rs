//! The host link: bytes in, replies out.
//!
//! [`LinkServer`] turns the byte stream from the USART into requests, serves
//! them, and encodes one reply frame per request. Damaged frames are answered
//! with a typed error and counted; nothing here can panic on what arrives.

use magcal_protocol::endpoint::Pong;
use magcal_protocol::{
    self as proto, Call, Endpoint, FrameDecoder, Identity, DeviceError, Name, Platform, Request, RequestBody,
    Response, ResponseBody, MAX_FRAME_LEN,
};

/// What the link server needs to know about the device to answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Where the firmware runs.
    pub platform: Platform,
    /// Milliseconds since boot.
    pub uptime_ms: u32,
}

/// Counters of the link's health.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkCounters {
    /// Requests decoded and served.
    pub requests: u32,
    /// Frames refused as damaged, oversized or of another version.
    pub bad_frames: u32,
    /// Replies that could not be encoded (a firmware bug if ever non-zero).
    pub encode_failures: u32,
}

/// One encoded reply frame.
pub type ReplyFrame = heapless::Vec<u8, MAX_FRAME_LEN>;

/// What a received byte led to.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkEvent {
    /// A reply the link layer produced itself (ping, identify, damaged frame).
    Reply(ReplyFrame),
    /// A request for the device; answer it with [`LinkServer::reply`].
    Request(Request),
}

/// Frame receiver plus request handler.
#[derive(Debug, Default)]
pub struct LinkServer {
    decoder: FrameDecoder,
    counters: LinkCounters,
}

impl LinkServer {
    /// A server with an empty receive buffer and zeroed counters.
    pub const fn new() -> Self {
        Self {
            decoder: FrameDecoder::new(),
            counters: LinkCounters { requests: 0, bad_frames: 0, encode_failures: 0 },
        }
    }

    /// The link's health counters.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Feeds one received byte. When it completes a frame: a reply for
    /// what the link answers itself (ping, identify, a damaged frame), or
    /// the request for the device.
    pub fn on_byte(&mut self, byte: u8, device: &DeviceInfo) -> Option<LinkEvent> {
        let decoded = self.decoder.push(byte)?;
        match decoded.and_then(proto::decode_body::<Request>) {
            Ok(request) => {
                self.counters.requests = self.counters.requests.wrapping_add(1);
                match serve(&request.body, device) {
                    Some(body) => self.reply(Some(request.seq), body).map(LinkEvent::Reply),
                    None => Some(LinkEvent::Request(request)),
                }
            }
            Err(e) => {
                self.counters.bad_frames = self.counters.bad_frames.wrapping_add(1);
                self.reply(None, ResponseBody::Error(DeviceError::Frame(e))).map(LinkEvent::Reply)
            }
        }
    }

    /// Encodes a response frame (also used for streamed samples, `seq: None`).
    pub fn reply(&mut self, seq: Option<u16>, body: ResponseBody) -> Option<ReplyFrame> {
        let response = Response { seq, body };
        let mut frame = [0u8; MAX_FRAME_LEN];
        match proto::encode(&response, &mut frame) {
            Ok(n) => frame.get(..n).and_then(|bytes| ReplyFrame::from_slice(bytes).ok()),
            Err(_) => {
                self.counters.encode_failures = self.counters.encode_failures.wrapping_add(1);
                None
            }
        }
    }
}

/// A reply frame as sent while the stream is NMEA sentences: `0x00 ‖
/// frame ‖ \r\n`. The leading zero ends the sentence bytes a framed
/// reader has buffered (it then sees one damaged frame, counted, and this
/// one whole); the trailing line end makes the frame one line an NMEA
/// reader discards (it does not start with `$`).
pub fn nmea_safe(frame: &ReplyFrame) -> NmeaSafeFrame {
    let mut out = NmeaSafeFrame::new();
    // Cannot fail: the capacity is the frame's plus three.
    let _ = out.push(0);
    let _ = out.extend_from_slice(frame);
    let _ = out.extend_from_slice(b"\r\n");
    out
}

/// A reply frame with its NMEA-mode margins ([`nmea_safe`]).
pub type NmeaSafeFrame = heapless::Vec<u8, { MAX_FRAME_LEN + 3 }>;

/// The link's output policy for replies: in NMEA mode a framed reply goes
/// between sentences with its margins ([`nmea_safe`]), and the mode
/// *before* a request counts too — the reply to the request that leaves
/// NMEA mode follows sentence bytes (`docs/INTERFACES.md`).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct ReplyPolicy {
    nmea_before: bool,
}

/// The bytes of one outgoing reply.
#[derive(Debug, Clone, PartialEq)]
pub enum OutgoingReply {
    /// The frame as it is (framed streaming).
    Framed(ReplyFrame),
    /// With the NMEA-mode margins.
    NmeaSafe(NmeaSafeFrame),
}

impl OutgoingReply {
    /// The bytes to enqueue.
    pub fn bytes(&self) -> &[u8] {
        match self {
            OutgoingReply::Framed(f) => f,
            OutgoingReply::NmeaSafe(f) => f,
        }
    }
}

impl ReplyPolicy {
    /// A link that has not streamed NMEA yet.
    pub const fn new() -> Self {
        Self { nmea_before: false }
    }

    /// The reply as sent, given whether the stream is NMEA now (after the
    /// request was handled).
    pub fn outgoing(&mut self, frame: ReplyFrame, nmea_now: bool) -> OutgoingReply {
        let nmea = core::mem::replace(&mut self.nmea_before, nmea_now) || nmea_now;
        if nmea {
            OutgoingReply::NmeaSafe(nmea_safe(&frame))
        } else {
            OutgoingReply::Framed(frame)
        }
    }
}

/// The bytes of one streamed sample: the NMEA sentences in NMEA mode, else
/// its frame (`Response { seq: None, Sample }`); `None` when it cannot be
/// encoded (never for a valid sample: counted by the caller as dropped).
pub fn sample_bytes(sample: &proto::Sample, stream: proto::StreamMode, declination_rad: f32) -> Option<SampleBytes> {
    if stream == proto::StreamMode::Nmea {
        return Some(SampleBytes::Nmea(crate::nmea::sentences(sample, declination_rad)));
    }
    let mut buf = [0u8; MAX_FRAME_LEN];
    let len = proto::encode(&Response { seq: None, body: ResponseBody::Sample(*sample) }, &mut buf).ok()?;
    Some(SampleBytes::Framed { buf, len })
}

/// A streamed sample's bytes ([`sample_bytes`]).
#[derive(Debug, Clone, PartialEq)]
pub enum SampleBytes {
    /// The sample's frame: the first `len` bytes of `buf`, encoded in place.
    Framed {
        /// The encoding buffer.
        buf: [u8; MAX_FRAME_LEN],
        /// The frame's length.
        len: usize,
    },
    /// Its NMEA sentences.
    Nmea(crate::nmea::Burst),
}

impl SampleBytes {
    /// The bytes to enqueue.
    pub fn bytes(&self) -> &[u8] {
        match self {
            SampleBytes::Framed { buf, len } => buf.get(..*len).unwrap_or(&[]),
            SampleBytes::Nmea(b) => b,
        }
    }
}

/// The requests the link layer answers itself; `None` for the device's.
fn serve(body: &RequestBody, device: &DeviceInfo) -> Option<ResponseBody> {
    match Call::from(body.clone()) {
        Call::Ping(r) => Some(r.answer(Ok(Pong { nonce: r.nonce }))),
        Call::Identify(r) => Some(r.answer(Ok(Identity {
            name: short_name(crate::FIRMWARE_NAME),
            firmware_version: short_name(crate::FIRMWARE_VERSION),
            protocol_version: proto::PROTOCOL_VERSION,
            platform: device.platform,
            uptime_ms: device.uptime_ms,
        }))),
        _ => None,
    }
}

/// Copies as much of `s` as fits in a [`Name`].
fn short_name(s: &str) -> Name {
    let mut name = Name::new();
    for c in s.chars() {
        if name.push(c).is_err() {
            break;
        }
    }
    name
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use magcal_protocol::FrameError;

    /// The reply policy: framed while streaming frames, with the NMEA
    /// margins in NMEA mode, and for the one reply after NMEA mode ends.
    #[test]
    fn replies_get_nmea_margins_in_nmea_mode_and_just_after_it() {
        let frame = ReplyFrame::from_slice(&[7, 1, 2, 0]).unwrap();
        let mut p = ReplyPolicy::new();
        assert_eq!(p.outgoing(frame.clone(), false).bytes(), &[7, 1, 2, 0]);
        // The request that enters NMEA mode: its reply follows no sentence
        // yet, but the stream is NMEA now.
        assert_eq!(p.outgoing(frame.clone(), true).bytes(), &[0, 7, 1, 2, 0, b'\r', b'\n']);
        // The request that leaves it: its reply follows sentence bytes.
        assert!(matches!(p.outgoing(frame.clone(), false), OutgoingReply::NmeaSafe(_)));
        assert!(matches!(p.outgoing(frame, false), OutgoingReply::Framed(_)));
    }

    /// A streamed sample: its frame decodes back to it; in NMEA mode the
    /// sentences, no frame.
    #[test]
    fn samples_are_frames_or_sentences_by_the_stream_mode() {
        let sample = proto::Sample {
            t_ms: 1234,
            raw: Some([100.0, -200.0, 300.0]),
            field_nt: Some([20_000.0, 0.0, 40_000.0]),
            heading_rad: Some(0.5),
            saturated: false,
            feed_seq: None,
            temp_c: Some(21.5),
            heading_sigma_deg: Some(0.4),
            integrity: proto::Integrity::Ok,
        };
        let framed = sample_bytes(&sample, proto::StreamMode::Both, 0.0).unwrap();
        let back: Response = proto::decode(framed.bytes()).unwrap();
        assert_eq!(back, Response { seq: None, body: ResponseBody::Sample(sample) });
        let nmea = sample_bytes(&sample, proto::StreamMode::Nmea, 0.0).unwrap();
        assert!(matches!(nmea, SampleBytes::Nmea(_)) && nmea.bytes().starts_with(b"$"), "{:?}", core::str::from_utf8(nmea.bytes()));
    }

    const DEV: DeviceInfo = DeviceInfo { platform: Platform::Qemu, uptime_ms: 42 };

    fn feed(server: &mut LinkServer, bytes: &[u8]) -> Vec<Response> {
        bytes
            .iter()
            .filter_map(|&b| server.on_byte(b, &DEV))
            .map(|e| match e {
                LinkEvent::Reply(f) => proto::decode::<Response>(&f).unwrap(),
                LinkEvent::Request(r) => panic!("unexpected request {r:?}"),
            })
            .collect()
    }

    #[test]
    fn device_requests_are_handed_on() {
        let mut s = LinkServer::new();
        let f = frame(&Request { seq: 4, body: RequestBody::Status });
        let events: Vec<LinkEvent> = f.iter().filter_map(|&b| s.on_byte(b, &DEV)).collect();
        assert_eq!(events, vec![LinkEvent::Request(Request { seq: 4, body: RequestBody::Status })]);
    }

    fn frame(req: &Request) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = proto::encode(req, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn identify_reports_name_version_protocol_and_platform() {
        let mut s = LinkServer::new();
        let replies = feed(&mut s, &frame(&Request { seq: 9, body: RequestBody::Identify }));
        assert_eq!(replies.len(), 1);
        assert_eq!(replies[0].seq, Some(9));
        match &replies[0].body {
            ResponseBody::Identity(id) => {
                assert_eq!(id.name.as_str(), "magcal-fw");
                assert_eq!(id.firmware_version.as_str(), env!("CARGO_PKG_VERSION"));
                assert_eq!(id.protocol_version, proto::PROTOCOL_VERSION);
                assert_eq!(id.platform, Platform::Qemu);
                assert_eq!(id.uptime_ms, 42);
            }
            other => panic!("unexpected {other:?}"),
        }
        assert_eq!(s.counters().requests, 1);
    }

    #[test]
    fn damaged_frame_gets_a_typed_error_and_the_next_request_is_served() {
        let mut s = LinkServer::new();
        let mut bad = frame(&Request { seq: 1, body: RequestBody::Ping { nonce: 5 } });
        bad[2] ^= 0x10;
        let good = frame(&Request { seq: 2, body: RequestBody::Ping { nonce: 6 } });
        let replies = feed(&mut s, &[bad, good].concat());
        assert_eq!(replies.len(), 2);
        assert_eq!(replies[0].seq, None);
        assert!(matches!(
            replies[0].body,
            ResponseBody::Error(DeviceError::Frame(FrameError::Crc | FrameError::Cobs))
        ));
        assert_eq!(replies[1], Response { seq: Some(2), body: ResponseBody::Pong { nonce: 6 } });
        assert_eq!(s.counters(), LinkCounters { requests: 1, bad_frames: 1, encode_failures: 0 });
    }

    /// In NMEA mode a framed reader that has buffered sentence bytes loses
    /// them (one damaged frame) but decodes the reply whole.
    #[test]
    fn a_reply_after_nmea_sentences_still_decodes() {
        let mut s = LinkServer::new();
        let reply = s.reply(Some(3), ResponseBody::Ack).unwrap();
        let mut bytes = b"$HCHDT,123.4,T*1D\r\n$PMAGI,0.73,ok*3C\r\n".to_vec();
        bytes.extend_from_slice(&nmea_safe(&reply));
        bytes.extend_from_slice(b"$HCHDT,,T*2C\r\n");
        let mut dec = FrameDecoder::new();
        let got: Vec<Result<Response, FrameError>> = bytes.iter().filter_map(|&b| dec.push(b).map(|r| r.and_then(proto::decode_body::<Response>))).collect();
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got[0].is_err());
        assert_eq!(got[1], Ok(Response { seq: Some(3), body: ResponseBody::Ack }));
        assert!(nmea_safe(&reply).ends_with(b"\r\n") && nmea_safe(&reply)[0] == 0);
    }

    #[test]
    fn garbage_without_delimiters_is_bounded_and_reported_once() {
        let mut s = LinkServer::new();
        let mut junk = vec![0xA5u8; 5000];
        junk.push(0);
        let replies = feed(&mut s, &junk);
        assert_eq!(replies.len(), 1);
        assert_eq!(replies[0].body, ResponseBody::Error(DeviceError::Frame(FrameError::TooLong)));
    }
}

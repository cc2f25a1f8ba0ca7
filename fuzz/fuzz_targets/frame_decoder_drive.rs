//! Arbitrary bytes on the host link: the firmware's whole request path
//! (frame decoder, link server, device) must answer or ignore, never panic,
//! and never switch coefficients without a valid unlock and commit.
//!
//! A shadow of what the protocol allows is kept beside the device: a
//! `Committed` reply must follow an acknowledged `Unlock` and an acknowledged
//! `WriteCoefficients` whose set has the committed CRC; the store must then
//! hold exactly that set, and reading back must give it. Seeds in
//! `fuzz/seeds/frame_decoder/` (valid unlock/write/commit sequences, written
//! by the firmware's `fuzz_seed_corpus_is_current` test) let the fuzzer start
//! on the deep paths.
//!
//! The `frame_decoder` fuzz target's body, a plain function: libFuzzer calls it
//! through `frame_decoder.rs`, and `cargo xtask test` replays every seed and
//! corpus input through it (`xtask/src/fuzz.rs`, `replay`).
use firmware::device::{decode_coefficients, BoardCounters, Boot, CoefficientStore, Device};
use firmware::link::{DeviceInfo, LinkEvent, LinkServer};
use magcal_protocol::{self as proto, CoefficientSource, Coefficients, Platform, Request, RequestBody, Response, ResponseBody};

/// The challenge the seeds are made for (`firmware::device::FUZZ_CHALLENGE`).
const CHALLENGE: u32 = firmware::device::FUZZ_CHALLENGE;

#[derive(Default)]
struct Store {
    saved: Vec<Vec<u8>>,
}
impl CoefficientStore for Store {
    fn save(&mut self, bytes: &[u8]) -> Result<u32, firmware::device::SaveFailed> {
        self.saved.push(bytes.to_vec());
        Ok(self.saved.len() as u32)
    }
}

/// Runs one input.
pub fn drive(data: &[u8]) {
    let mut link = LinkServer::new();
    let mut device = Device::new(Boot { stored: None, challenge: CHALLENGE });
    let mut store = Store::default();
    let info = DeviceInfo { platform: Platform::Qemu, uptime_ms: 0 };
    let board = BoardCounters::default();
    // The shadow: what the protocol has allowed so far.
    let mut unlocked = false;
    let mut staged: Option<Coefficients> = None;
    let mut counters = link.counters();
    for &b in data {
        match link.on_byte(b, &info) {
            Some(LinkEvent::Reply(frame)) => {
                assert!(proto::decode::<Response>(&frame).is_ok(), "the link's own reply must decode");
            }
            Some(LinkEvent::Request(Request { seq, body })) => {
                let reply = device.handle(&body, 0, &mut store, &board);
                match (&body, &reply) {
                    (RequestBody::Unlock { .. }, ResponseBody::Ack) => unlocked = true,
                    (RequestBody::WriteCoefficients(c), ResponseBody::Ack) => {
                        assert!(unlocked, "a write was accepted without an unlock");
                        staged = Some(*c);
                    }
                    (RequestBody::Commit { crc }, ResponseBody::Committed { seq: committed }) => {
                        assert!(unlocked, "a commit was accepted without an unlock");
                        let Some(set) = staged.take() else { panic!("a commit was accepted with nothing staged") };
                        assert_eq!(set.crc(), *crc, "the commit quoted another set's CRC");
                        let Some(last) = store.saved.last() else { panic!("committed without storing") };
                        assert_eq!(decode_coefficients(last, firmware::store::VERSION).map(|(c, _)| c), Some(set), "the store holds another set");
                        let back = device.handle(&RequestBody::ReadCoefficients, 0, &mut store, &board);
                        assert_eq!(back, ResponseBody::Coefficients { coefficients: set, source: CoefficientSource::Stored, seq: *committed });
                        unlocked = false;
                    }
                    (RequestBody::SetMissionMode { enabled: true }, ResponseBody::Ack) => {
                        unlocked = false;
                        staged = None;
                    }
                    _ => {}
                }
                if let Some(frame) = link.reply(Some(seq), reply) {
                    assert!(proto::decode::<Response>(&frame).is_ok(), "every reply must decode");
                }
            }
            None => {}
        }
        let now = link.counters();
        assert!(now.bad_frames >= counters.bad_frames && now.requests >= counters.requests, "counters only grow");
        counters = now;
    }
    // The device uses stored coefficients exactly when the store has some.
    let r = device.handle(&RequestBody::ReadCoefficients, 0, &mut store, &board);
    let ResponseBody::Coefficients { source, .. } = r else { panic!("{r:?}") };
    assert_eq!(source == CoefficientSource::Stored, !store.saved.is_empty());
}

//! Arbitrary bytes on the host link: the firmware's whole request path
//! (frame decoder, link server, device) must answer or ignore, never panic,
//! and never switch coefficients without a valid unlock and commit.
#![no_main]
use firmware::device::{BoardCounters, Boot, CoefficientStore, Device};
use firmware::link::{DeviceInfo, LinkEvent, LinkServer};
use libfuzzer_sys::fuzz_target;
use magcal_protocol::{self as proto, CoefficientSource, Platform, Request, RequestBody, Response, ResponseBody};

struct Store(u32);
impl CoefficientStore for Store {
    fn save(&mut self, _: &[u8]) -> Result<u32, ()> {
        self.0 += 1;
        Ok(self.0)
    }
}

fuzz_target!(|data: &[u8]| {
    let mut link = LinkServer::new();
    let mut device = Device::new(Boot { stored: None, challenge: 0x5EED });
    let mut store = Store(0);
    let info = DeviceInfo { platform: Platform::Qemu, uptime_ms: 0 };
    for &b in data {
        match link.on_byte(b, &info) {
            Some(LinkEvent::Reply(frame)) => {
                assert!(proto::decode::<Response>(&frame).is_ok());
            }
            Some(LinkEvent::Request(Request { seq, body })) => {
                let reply = device.handle(&body, 0, &mut store, &BoardCounters::default());
                if let ResponseBody::Committed { .. } = reply {
                    // Only a commit after an unlock with the right key gets here.
                    assert!(matches!(body, RequestBody::Commit { .. }));
                }
                let _ = link.reply(Some(seq), reply);
            }
            None => {}
        }
    }
    let _ = proto::decode::<Request>(data);
    if store.0 == 0 {
        let r = device.handle(&RequestBody::ReadCoefficients, 0, &mut store, &BoardCounters::default());
        assert!(matches!(r, ResponseBody::Coefficients { source: CoefficientSource::Default, .. }));
    }
});

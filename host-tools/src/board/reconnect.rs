//! Getting the link back after it drops: the session's recording and
//! `magcal log` both reopen the link this way.

use std::io::{Read, Write};
use std::time::Duration;

use magcal_protocol::StreamMode;

use super::client::{BoardClient, ClientError};

/// How to get the link back when it drops mid-recording.
pub struct Resume<'a, P> {
    /// Opens the link again.
    pub connect: &'a mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    /// What the board streams (set again after reconnecting).
    pub stream: StreamMode,
    /// Attempts per drop.
    pub attempts: u32,
}

/// Opens the link again (up to `r.attempts` times, at least once, 200 ms
/// apart) and restarts the stream at `rate_hz`; the last attempt's error
/// when none succeeds.
pub fn reconnect_at<P: Read + Write>(r: &mut Resume<'_, P>, rate_hz: u8) -> Result<BoardClient<P>, ClientError> {
    let attempts = r.attempts.max(1);
    let mut attempt = 1;
    loop {
        let opened = (r.connect)().and_then(|mut l| l.set_stream(r.stream).and_then(|()| l.set_output_rate(rate_hz)).map(|()| l));
        let e = match opened {
            Ok(l) => return Ok(l),
            Err(e) => e,
        };
        std::thread::sleep(Duration::from_millis(200));
        if attempt >= attempts {
            return Err(e);
        }
        attempt += 1;
    }
}

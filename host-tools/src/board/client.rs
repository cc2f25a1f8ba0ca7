//! [`BoardClient`]: the host's end of the serial link to the board — framed
//! requests, matched replies, retries, and the samples the board streams.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use magcal_protocol::endpoint as ep;
use magcal_protocol::{
    self as proto, Endpoint, Reply, Coefficients, CoefficientSource, OnboardModel, FitReport, FrameDecoder, FrameError, Health, Identity, Request,
    RequestBody, Response, ResponseBody, Sample, StreamMode, MAX_FRAME_LEN, UNLOCK_XOR,
};

/// Streamed samples kept while waiting for replies; beyond this the oldest
/// are dropped and counted.
pub const SAMPLE_QUEUE: usize = 100_000;

/// The link's baud rate (the firmware's USART1 setting).
pub const BAUD_RATE: u32 = 115_200;

/// Opens a serial port (a board's USB-serial adapter, or a QEMU pty) at
/// [`BAUD_RATE`], 8N1, with a short read timeout.
pub(crate) fn open_port(path: &str) -> Result<Box<dyn serialport::SerialPort>, ClientError> {
    serialport::new(path, BAUD_RATE)
        .timeout(Duration::from_millis(20))
        .open()
        .map_err(|source| ClientError::Open { path: path.to_string(), source })
}

/// Why a request failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The serial port could not be opened.
    #[error("cannot open serial port {path}: {source}")]
    Open {
        /// The port's path.
        path: String,
        /// What the OS said.
        #[source]
        source: serialport::Error,
    },
    /// Reading or writing the port failed.
    #[error("serial I/O: {0}")]
    Io(#[from] io::Error),
    /// No reply within the timeout, after every retry.
    #[error("no reply from the board after {attempts} attempt(s) of {timeout_ms} ms")]
    Timeout {
        /// Attempts made.
        attempts: u32,
        /// Per-attempt timeout.
        timeout_ms: u64,
    },
    /// The request could not be framed (a host bug).
    #[error("cannot encode request: {0}")]
    Encode(FrameError),
    /// The board said our frame was bad, or refused the request.
    #[error("board refused the request: {0}")]
    Remote(proto::DeviceError),
    /// The board answered with something that does not answer the request.
    #[error("unexpected reply: {0:?}")]
    Unexpected(Box<ResponseBody>),
    /// The coefficients read back after a commit are not the ones committed.
    #[error("read-back differs: the board holds record #{back_seq} (stored: {stored}), the commit made #{seq}, or other values")]
    ReadBackDiffers {
        /// The committed record's sequence number.
        seq: u32,
        /// The sequence number read back.
        back_seq: u32,
        /// Whether the coefficients read back are the stored set.
        stored: bool,
    },
}

/// How long a receiver may take nothing before a send gives up (beyond
/// the bytes' own line time): a board or QEMU descheduled for seconds on a
/// loaded host is slow, not gone.
pub const SEND_STALL: Duration = Duration::from_secs(5);

/// A request/response client over any byte stream (a serial port, a pty, a
/// test double).
pub struct BoardClient<P> {
    port: P,
    decoder: FrameDecoder,
    /// Bytes read from the port but not yet fed to the decoder (a read may
    /// return the end of one frame and the start of the next).
    unread: VecDeque<u8>,
    next_seq: u16,
    /// Per-attempt reply timeout.
    pub timeout: Duration,
    /// How long a send waits on a receiver that takes nothing ([`SEND_STALL`]).
    pub send_stall: Duration,
    /// Attempts per request (idempotent requests are simply resent).
    pub attempts: u32,
    /// Frames received that were damaged or answered an older request.
    pub discarded_frames: u32,
    /// Streamed samples received and not yet taken.
    samples: VecDeque<Sample>,
    /// Samples dropped because the queue was full.
    pub dropped_samples: u64,
}

impl BoardClient<Box<dyn serialport::SerialPort>> {
    /// Opens a serial port (a board's USB-serial adapter, or QEMU's pty) at
    /// [`BAUD_RATE`], 8N1.
    pub fn open(path: &str) -> Result<Self, ClientError> {
        Ok(BoardClient::new(open_port(path)?))
    }
}

impl<P: Read + Write> BoardClient<P> {
    /// Wraps a byte stream whose reads time out (return `TimedOut` or
    /// `WouldBlock`, or 0 bytes) rather than block forever.
    pub fn new(port: P) -> Self {
        Self {
            port,
            decoder: FrameDecoder::new(),
            unread: VecDeque::new(),
            next_seq: 1,
            timeout: Duration::from_millis(1500),
            send_stall: SEND_STALL,
            attempts: 3,
            discarded_frames: 0,
            samples: VecDeque::new(),
            dropped_samples: 0,
        }
    }

    fn keep_sample(&mut self, s: Sample) {
        if self.samples.len() >= SAMPLE_QUEUE {
            self.samples.pop_front();
            self.dropped_samples += 1;
        }
        self.samples.push_back(s);
    }

    /// The next streamed sample, waiting up to `timeout` (a zero timeout
    /// still reads what has arrived).
    pub fn next_sample(&mut self, timeout: Duration) -> Result<Option<Sample>, ClientError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.samples.pop_front() {
                return Ok(Some(s));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.pump(left, true)? {
                Some(_) => self.discarded_frames += 1,
                None if self.samples.is_empty() && Instant::now() >= deadline => return Ok(None),
                None => {}
            }
        }
    }

    /// Drops the samples queued so far.
    pub fn clear_samples(&mut self) {
        self.samples.clear();
    }

    /// The underlying byte stream.
    pub fn into_port(self) -> P {
        self.port
    }

    /// Sends raw bytes as they are (for tests of the board's error paths).
    ///
    /// A write may wait on a busy receiver (a full pty while QEMU is not
    /// scheduled, a USB adapter still draining) longer than the port's
    /// 20 ms timeout, which paces reads: the bytes go out in as many writes
    /// as it takes, and only when the receiver has taken nothing for
    /// [`BoardClient::send_stall`] more than the bytes' own line time at [`BAUD_RATE`] is
    /// the last `TimedOut` returned. (`write_all` gave up at the first
    /// 20 ms wait: an end-to-end test failed once that way under load.)
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), ClientError> {
        let line_time = Duration::from_secs_f64(bytes.len() as f64 * 10.0 / f64::from(BAUD_RATE));
        let mut rest = bytes;
        let mut last_progress = Instant::now();
        while !rest.is_empty() {
            match self.port.write(rest) {
                Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero).into()),
                Ok(n) => {
                    rest = rest.get(n..).unwrap_or_default();
                    last_progress = Instant::now();
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => {
                    if last_progress.elapsed() > self.send_stall + line_time {
                        return Err(e.into());
                    }
                }
                Err(e) => return Err(e.into()),
            }
        }
        self.port.flush()?;
        Ok(())
    }

    /// Waits for the next well-formed response frame, whatever its `seq`.
    /// Streamed samples that arrive meanwhile are kept for [`BoardClient::next_sample`].
    pub fn next_response(&mut self, timeout: Duration) -> Result<Option<Response>, ClientError> {
        self.pump(timeout, false)
    }

    /// Reads until a response arrives, or (with `stop_on_sample`) a sample
    /// was queued, or the timeout passes. The port is read at least once.
    fn pump(&mut self, timeout: Duration, stop_on_sample: bool) -> Result<Option<Response>, ClientError> {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; 256];
        let mut read_once = false;
        loop {
            let mut got_sample = false;
            while let Some(b) = self.unread.pop_front() {
                match self.decoder.push(b) {
                    None => {}
                    Some(Ok(body)) => match proto::decode_body::<Response>(body) {
                        Ok(Response { seq: None, body: ResponseBody::Sample(s) }) => {
                            self.keep_sample(s);
                            got_sample = true;
                        }
                        Ok(r) => return Ok(Some(r)),
                        Err(_) => self.discarded_frames += 1,
                    },
                    Some(Err(_)) => self.discarded_frames += 1,
                }
            }
            if (stop_on_sample && got_sample) || (read_once && Instant::now() >= deadline) {
                return Ok(None);
            }
            read_once = true;
            match self.port.read(&mut buf) {
                Ok(0) => std::thread::sleep(Duration::from_millis(1)),
                Ok(n) => self.unread.extend(buf.iter().take(n)),
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Sends a request and returns the matching reply body, resending on
    /// timeout up to [`BoardClient::attempts`] times. Replies to older requests are
    /// discarded; an error reply without a `seq` (our frame was damaged on the
    /// way) triggers a resend.
    pub fn request(&mut self, body: RequestBody) -> Result<ResponseBody, ClientError> {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1).max(1);
        let mut frame = [0u8; MAX_FRAME_LEN + 1];
        // A leading delimiter flushes whatever partial frame the board holds.
        let n = proto::encode(&Request { seq, body }, &mut frame[1..]).map_err(ClientError::Encode)?;
        // An error reply without a seq may answer our frame (damaged on the
        // way) or older garbage still queued: keep waiting for our own
        // reply until the attempt's deadline, and resend only then.
        let mut last_remote = None;
        for _ in 0..self.attempts {
            self.send_raw(&frame[..n + 1])?;
            let deadline = Instant::now() + self.timeout;
            while let Some(left) = deadline.checked_duration_since(Instant::now()) {
                match self.next_response(left)? {
                    Some(Response { seq: Some(s), body }) if s == seq => {
                        return match body {
                            ResponseBody::Error(e) => Err(ClientError::Remote(e)),
                            other => Ok(other),
                        };
                    }
                    Some(Response { seq: None, body: ResponseBody::Error(e) }) => last_remote = Some(e),
                    Some(_) => self.discarded_frames += 1,
                    None => break,
                }
            }
        }
        match last_remote {
            Some(e) => Err(ClientError::Remote(e)),
            None => Err(ClientError::Timeout {
                attempts: self.attempts,
                timeout_ms: self.timeout.as_millis() as u64,
            }),
        }
    }

    /// Sends one endpoint's request and returns its typed answer (the
    /// protocol's endpoint table pairs each request with the one kind of
    /// reply it gets; any other reply is [`ClientError::Unexpected`]).
    pub fn call<E: Endpoint>(&mut self, req: E) -> Result<E::Response, ClientError> {
        E::Response::from_body(self.request(req.into_body())?).map_err(|other| ClientError::Unexpected(Box::new(other)))
    }

    /// Asks the board who it is.
    pub fn identify(&mut self) -> Result<Identity, ClientError> {
        self.call(ep::Identify)
    }

    /// The board's counters and state.
    pub fn status(&mut self) -> Result<Health, ClientError> {
        self.call(ep::Status)
    }

    /// Chooses what is streamed.
    pub fn set_stream(&mut self, mode: StreamMode) -> Result<(), ClientError> {
        self.call(ep::SetStream(mode)).map(|ep::Ack| ())
    }

    /// Sets the output rate (1–100 Hz).
    pub fn set_output_rate(&mut self, hz: u8) -> Result<(), ClientError> {
        self.call(ep::SetOutputRate { hz }).map(|ep::Ack| ())
    }

    /// Sends the vehicle's attitude.
    pub fn attitude(&mut self, roll_rad: f32, pitch_rad: f32) -> Result<(), ClientError> {
        self.call(ep::Attitude { roll_rad, pitch_rad }).map(|ep::Ack| ())
    }

    /// Sends the vehicle's attitude and body rates (for the heading and the
    /// board's gyro-aided fit).
    pub fn motion(&mut self, roll_rad: f32, pitch_rad: f32, rate_rad_s: [f32; 3]) -> Result<(), ClientError> {
        self.call(ep::Motion { roll_rad, pitch_rad, rate_rad_s }).map(|ep::Ack| ())
    }

    /// Sends the vehicle's attitude with the thrusters' (motor) current, A,
    /// for the board's current term.
    pub fn attitude_env(&mut self, roll_rad: f32, pitch_rad: f32, motor_current_a: f32) -> Result<(), ClientError> {
        self.call(ep::AttitudeEnv { roll_rad, pitch_rad, motor_current_a }).map(|ep::Ack| ())
    }

    /// Enters or leaves mission mode.
    pub fn set_mission_mode(&mut self, enabled: bool) -> Result<(), ClientError> {
        self.call(ep::SetMissionMode { enabled }).map(|ep::Ack| ())
    }

    /// Starts the on-board fit.
    pub fn fit_start(&mut self, model: OnboardModel, field_nt: f32) -> Result<FitReport, ClientError> {
        self.call(ep::FitStart { model, field_nt })
    }

    /// The on-board fit's state.
    pub fn fit_query(&mut self) -> Result<FitReport, ClientError> {
        self.call(ep::FitQuery)
    }

    /// Stops the on-board fit.
    pub fn fit_stop(&mut self) -> Result<FitReport, ClientError> {
        self.call(ep::FitStop)
    }

    /// The coefficients in use.
    pub fn read_coefficients(&mut self) -> Result<(Coefficients, CoefficientSource, u32), ClientError> {
        self.call(ep::ReadCoefficients).map(|ep::InUse { coefficients, source, seq }| (coefficients, source, seq))
    }

    /// Unlock, stage, commit, read back and compare: the only way the host
    /// writes coefficients. Returns the stored record's sequence number.
    pub fn upload_coefficients(&mut self, c: &Coefficients) -> Result<u32, ClientError> {
        let challenge = self.status()?.unlock_challenge;
        self.call(ep::Unlock { key: challenge ^ UNLOCK_XOR })?;
        self.call(ep::WriteCoefficients(*c))?;
        let ep::Committed { seq } = self.call(ep::Commit { crc: c.crc() })?;
        let (back, source, back_seq) = self.read_coefficients()?;
        if back != *c || source != CoefficientSource::Stored || back_seq != seq {
            return Err(ClientError::ReadBackDiffers { seq, back_seq, stored: source == CoefficientSource::Stored });
        }
        Ok(seq)
    }

    /// Round-trip check: returns the echoed nonce.
    pub fn ping(&mut self, nonce: u32) -> Result<u32, ClientError> {
        self.call(ep::Ping { nonce }).map(|ep::Pong { nonce }| nonce)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    /// A scripted board: answers each complete request frame with a reply
    /// produced by `answer`, optionally dropping the first `drop_first`.
    struct FakeBoard<F> {
        rx: FrameDecoder,
        out: VecDeque<u8>,
        answer: F,
        drop_first: u32,
    }
    impl<F: FnMut(Request) -> Vec<Response>> Write for FakeBoard<F> {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            for &b in buf {
                if let Some(Ok(body)) = self.rx.push(b) {
                    let req: Request = proto::decode_body(body).unwrap();
                    if self.drop_first > 0 {
                        self.drop_first -= 1;
                        continue;
                    }
                    for r in (self.answer)(req) {
                        let mut f = [0u8; MAX_FRAME_LEN];
                        let n = proto::encode(&r, &mut f).unwrap();
                        self.out.extend(&f[..n]);
                    }
                }
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }
    impl<F> Read for FakeBoard<F> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = buf.len().min(self.out.len());
            for (i, b) in self.out.drain(..n).enumerate() {
                buf[i] = b;
            }
            Ok(n)
        }
    }

    fn board<F: FnMut(Request) -> Vec<Response>>(answer: F, drop_first: u32) -> BoardClient<FakeBoard<F>> {
        let mut l = BoardClient::new(FakeBoard { rx: FrameDecoder::new(), out: VecDeque::new(), answer, drop_first });
        l.timeout = Duration::from_millis(50);
        l
    }

    #[test]
    fn stale_replies_are_skipped_and_the_matching_one_returned() {
        let mut link = board(
            |q| {
                vec![
                    Response { seq: Some(q.seq.wrapping_sub(1)), body: ResponseBody::Pong { nonce: 1 } },
                    Response { seq: Some(q.seq), body: ResponseBody::Pong { nonce: 77 } },
                ]
            },
            0,
        );
        assert_eq!(link.ping(77).unwrap(), 77);
        assert_eq!(link.discarded_frames, 1);
    }

    /// A receiver that is slow to take bytes: each write first times out
    /// `stalls_per_write` times, then takes at most `chunk` bytes.
    struct SlowReceiver {
        got: Vec<u8>,
        stalls_per_write: u32,
        stalled: u32,
        chunk: usize,
    }
    impl Write for SlowReceiver {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.stalled < self.stalls_per_write {
                self.stalled += 1;
                return Err(io::ErrorKind::TimedOut.into());
            }
            self.stalled = 0;
            let n = buf.len().min(self.chunk);
            self.got.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }
    impl Read for SlowReceiver {
        fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
            Err(io::ErrorKind::TimedOut.into())
        }
    }

    /// A flood sent to a receiver that keeps timing out (a full
    /// pty while QEMU is descheduled) arrives whole, in order; `write_all`
    /// gave up at the first timeout. A receiver that takes nothing at all is
    /// given up on after the stall allowance.
    #[test]
    fn a_send_waits_for_a_slow_receiver_and_gives_up_on_a_dead_one() {
        let bytes: Vec<u8> = (0..20_000u32).map(|i| (i % 251) as u8).collect();
        let mut c = BoardClient::new(SlowReceiver { got: Vec::new(), stalls_per_write: 3, stalled: 0, chunk: 64 });
        c.send_raw(&bytes).expect("sent whole");
        assert_eq!(c.port.got, bytes);
        let mut dead = BoardClient::new(SlowReceiver { got: Vec::new(), stalls_per_write: u32::MAX, stalled: 0, chunk: 64 });
        dead.send_stall = Duration::from_millis(30);
        let t0 = Instant::now();
        assert!(matches!(dead.send_raw(&[1, 2, 3]), Err(ClientError::Io(_))));
        assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    }

    /// A typed call takes only its endpoint's kind of reply: a board that
    /// acknowledges everything serves `SetStream` but not `Status`.
    #[test]
    fn a_call_takes_only_its_endpoints_reply_kind() {
        let mut link = board(|q| vec![Response { seq: Some(q.seq), body: ResponseBody::Ack }], 0);
        assert!(link.set_stream(StreamMode::Raw).is_ok());
        assert!(matches!(link.call(ep::Status), Err(ClientError::Unexpected(b)) if *b == ResponseBody::Ack));
        assert!(matches!(link.call(ep::Commit { crc: 1 }), Err(ClientError::Unexpected(_))));
    }

    #[test]
    fn a_lost_request_is_resent() {
        let mut link = board(|q| vec![Response { seq: Some(q.seq), body: ResponseBody::Pong { nonce: 5 } }], 2);
        assert_eq!(link.ping(5).unwrap(), 5);
    }

    #[test]
    fn silence_is_a_timeout_with_the_attempt_count() {
        let mut link = board(|_| vec![], 0);
        link.attempts = 2;
        match link.ping(1) {
            Err(ClientError::Timeout { attempts: 2, timeout_ms: 50 }) => {}
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_remote_refusal_is_reported_not_retried_forever() {
        let mut link = board(
            |q| vec![Response { seq: Some(q.seq), body: ResponseBody::Error(proto::DeviceError::Unsupported) }],
            0,
        );
        assert!(matches!(link.identify(), Err(ClientError::Remote(proto::DeviceError::Unsupported))));
    }
}

//! The CRC-32 both the frames and the coefficient commit use (a leaf: the
//! ICD needs it for [`crate::Coefficients::crc`] without knowing how frames
//! travel, and [`crate::frame`] for its trailer).

/// CRC-32/ISO-HDLC (the Ethernet/zip polynomial; check value `0xCBF43926`),
/// computed bit by bit: the 1 KiB table would cost the board's flash more
/// than the ~40 instructions a byte cost its CPU (a 50-byte sample frame at
/// 100 Hz: 0.1 % of the M4F).
pub const CRC32: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

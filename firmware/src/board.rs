//! One binary, two boards: the hardware the firmware drives is either the
//! STM32F405 board or the QEMU board, chosen at boot. These wrappers give
//! both the same embedded-hal types, so the driver and everything above it
//! are the same code on both.

use core::convert::Infallible;

use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal_async::digital::Wait;
use embedded_hal::spi::{Error as SpiErrorTrait, ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_storage::nor_flash::NorFlash;

use magcal_protocol::Coefficients;

use crate::ads131m04_model::{Ads131m04Model, DrdyPinModel, StrapPinModel};
use crate::device::{decode_coefficients, CoefficientStore, SaveFailed};
use crate::store::{RamFlash, Record, Store, StoreError};

/// The ADC's bus: the real SPI device, or the simulated ADC.
pub enum BoardSpi<R> {
    /// SPI1 with its chip select (board).
    Real(R),
    /// The ADS131M04 model (QEMU).
    Model(Ads131m04Model),
}

/// An SPI error of either bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardSpiError(pub ErrorKind);

impl SpiErrorTrait for BoardSpiError {
    fn kind(&self) -> ErrorKind {
        self.0
    }
}

#[cfg(target_os = "none")]
impl defmt::Format for BoardSpiError {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "spi error")
    }
}

impl<R: SpiDevice> ErrorType for BoardSpi<R> {
    type Error = BoardSpiError;
}

impl<R: SpiDevice> SpiDevice for BoardSpi<R> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), BoardSpiError> {
        match self {
            BoardSpi::Real(r) => r.transaction(operations).map_err(|e| BoardSpiError(e.kind())),
            BoardSpi::Model(s) => s.transaction(operations).map_err(|e: Infallible| match e {}),
        }
    }
}

/// A strap pin: a GPIO, or the simulated one.
pub enum BoardPin<P> {
    /// A push-pull output (board).
    Real(P),
    /// The simulated strap (QEMU).
    Model(StrapPinModel),
}

impl<P: OutputPin> PinErrorType for BoardPin<P> {
    type Error = embedded_hal::digital::ErrorKind;
}

impl<P: OutputPin> OutputPin for BoardPin<P> {
    fn set_high(&mut self) -> Result<(), Self::Error> {
        match self {
            BoardPin::Real(p) => p.set_high().map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardPin::Model(p) => p.set_high().map_err(|e: Infallible| match e {}),
        }
    }
    fn set_low(&mut self) -> Result<(), Self::Error> {
        match self {
            BoardPin::Real(p) => p.set_low().map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardPin::Model(p) => p.set_low().map_err(|e: Infallible| match e {}),
        }
    }
}

/// The ADC's DRDY: the EXTI-backed pin (board) or the model's (QEMU, where
/// GPIO and EXTI are not modelled).
pub enum BoardDrdy<P> {
    /// A GPIO input with its EXTI line (board).
    Real(P),
    /// The simulated ADC's DRDY (QEMU).
    Model(DrdyPinModel),
}

impl<P: InputPin> PinErrorType for BoardDrdy<P> {
    type Error = embedded_hal::digital::ErrorKind;
}

impl<P: InputPin> InputPin for BoardDrdy<P> {
    fn is_high(&mut self) -> Result<bool, Self::Error> {
        match self {
            BoardDrdy::Real(p) => p.is_high().map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardDrdy::Model(p) => p.is_high().map_err(|e: Infallible| match e {}),
        }
    }
    fn is_low(&mut self) -> Result<bool, Self::Error> {
        match self {
            BoardDrdy::Real(p) => p.is_low().map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardDrdy::Model(p) => p.is_low().map_err(|e: Infallible| match e {}),
        }
    }
}

impl<P: InputPin + Wait> Wait for BoardDrdy<P> {
    async fn wait_for_high(&mut self) -> Result<(), Self::Error> {
        match self {
            BoardDrdy::Real(p) => p.wait_for_high().await.map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardDrdy::Model(p) => p.wait_for_high().await.map_err(|e: Infallible| match e {}),
        }
    }
    async fn wait_for_low(&mut self) -> Result<(), Self::Error> {
        match self {
            BoardDrdy::Real(p) => p.wait_for_low().await.map_err(|_| embedded_hal::digital::ErrorKind::Other),
            BoardDrdy::Model(p) => p.wait_for_low().await.map_err(|e: Infallible| match e {}),
        }
    }
    async fn wait_for_rising_edge(&mut self) -> Result<(), Self::Error> {
        self.wait_for_high().await
    }
    async fn wait_for_falling_edge(&mut self) -> Result<(), Self::Error> {
        self.wait_for_low().await
    }
    async fn wait_for_any_edge(&mut self) -> Result<(), Self::Error> {
        self.wait_for_low().await
    }
}

/// RAM "flash" of the QEMU board: two 1 KiB sectors.
pub type QemuFlash = RamFlash<2048, 1024>;

/// The coefficient store on either board.
pub enum BoardStore<F> {
    /// Flash sectors 1 and 2 (board; see [`crate::layout`]).
    Flash(Store<F>),
    /// RAM (QEMU; lost at reset, like a board whose flash was never written).
    Ram(Store<QemuFlash>),
}

impl<F: NorFlash> BoardStore<F> {
    /// The newest valid record (an error if the flash could not be read).
    pub fn load(&mut self) -> Result<Option<Record>, StoreError> {
        match self {
            BoardStore::Flash(s) => s.load(),
            BoardStore::Ram(s) => s.load(),
        }
    }

    /// The set to boot with and its sequence number: a read error is tried
    /// [`LOAD_ATTEMPTS`] times before it is reported (the board then runs on
    /// the nominal gain and says why; the store refuses to save); a record
    /// that does not decode or validate is no set.
    pub fn load_coefficients(&mut self) -> Result<Option<(Coefficients, u32)>, StoreError> {
        let loaded = (0..LOAD_ATTEMPTS).map(|_| self.load()).find(|r| r.is_ok()).unwrap_or(Err(StoreError::Flash))?;
        Ok(loaded.and_then(|r| decode_coefficients(&r.payload, r.version).map(|(c, _)| (c, r.seq))))
    }
}

/// Reads of the store at boot before a read error counts.
pub const LOAD_ATTEMPTS: usize = 3;

impl<F: NorFlash> CoefficientStore for BoardStore<F> {
    fn save(&mut self, bytes: &[u8]) -> Result<u32, SaveFailed> {
        match self {
            BoardStore::Flash(s) => s.save(bytes).map_err(|_| SaveFailed),
            BoardStore::Ram(s) => s.save(bytes).map_err(|_| SaveFailed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{default_coefficients, encode_coefficients};

    #[test]
    fn the_boot_load_finds_the_stored_set_and_refuses_a_bad_one() {
        let mut store: BoardStore<QemuFlash> = BoardStore::Ram(Store::new(QemuFlash::new(), 0, 1024, 1024).unwrap());
        assert_eq!(store.load_coefficients(), Ok(None));
        let c = default_coefficients();
        let mut buf = [0u8; Coefficients::MAX_ENCODED_LEN];
        let n = encode_coefficients(&c, &mut buf).unwrap();
        assert_eq!(store.save(&buf[..n]), Ok(1));
        assert_eq!(store.load_coefficients(), Ok(Some((c, 1))));
        // A record whose set fails validation (a mirrored axis) is no set.
        let mut mirrored = c;
        mirrored.matrix[0][0] = -mirrored.matrix[0][0];
        let n = encode_coefficients(&mirrored, &mut buf).unwrap();
        assert_eq!(store.save(&buf[..n]), Ok(2));
        assert_eq!(store.load_coefficients(), Ok(None));
    }
}

//! The board's view of the model through embedded-hal: the ADC as an SPI
//! device, its DRDY pin, the set/reset strap pins and a delay on the
//! model's clock.

use core::convert::Infallible;

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::converter::ADS_FRAME_BYTES;
use super::BridgeModel;

/// A strap GPIO of the simulated board: driving it high pulses the strap
/// and flips the bridges.
pub struct StrapPinModel {
    sensor: &'static BridgeModel,
    sign: i8,
}

impl StrapPinModel {
    /// The SET pulse pin.
    pub fn set(sensor: &'static BridgeModel) -> Self {
        Self { sensor, sign: 1 }
    }
    /// The RESET pulse pin.
    pub fn reset(sensor: &'static BridgeModel) -> Self {
        Self { sensor, sign: -1 }
    }
}

impl PinErrorType for StrapPinModel {
    type Error = Infallible;
}

impl OutputPin for StrapPinModel {
    fn set_high(&mut self) -> Result<(), Infallible> {
        let sign = self.sign;
        self.sensor.with(|w| w.flip(sign));
        Ok(())
    }
    fn set_low(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The ADC's DRDY pin (active low): readable, and awaitable — a wait lets
/// model time run to the next conversion.
pub struct DrdyPinModel {
    sensor: &'static BridgeModel,
}

impl DrdyPinModel {
    /// The pin of `sensor`'s converter.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        Self { sensor }
    }
}

impl PinErrorType for DrdyPinModel {
    type Error = Infallible;
}

impl InputPin for DrdyPinModel {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.sensor.drdy_low())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.sensor.drdy_low())
    }
}

impl embedded_hal_async::digital::Wait for DrdyPinModel {
    async fn wait_for_high(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
    async fn wait_for_low(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
    async fn wait_for_rising_edge(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
    async fn wait_for_falling_edge(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
    async fn wait_for_any_edge(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
}

/// A delay that lets model time pass (host tests), instead of spinning.
pub struct ModelDelay {
    sensor: &'static BridgeModel,
}

impl ModelDelay {
    /// Delays on `sensor`'s clock.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        Self { sensor }
    }
}

impl DelayNs for ModelDelay {
    fn delay_ns(&mut self, ns: u32) {
        self.sensor.advance_ns(u64::from(ns));
    }
}

/// The simulated ADS131M04.
pub struct Ads131m04Model {
    sensor: &'static BridgeModel,
}

impl Ads131m04Model {
    /// A device just powered on.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        sensor.with(|w| w.power_on());
        Self { sensor }
    }

    /// Frames exchanged so far.
    pub fn frames(&self) -> u32 {
        self.sensor.with(|w| w.frames)
    }
}

impl ErrorType for Ads131m04Model {
    type Error = Infallible;
}

impl SpiDevice for Ads131m04Model {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        self.sensor.with(|w| {
            for op in operations.iter_mut() {
                match op {
                    Operation::Transfer(rx, tx) => w.exchange(tx, rx),
                    Operation::TransferInPlace(buf) => {
                        let mut tx = [0u8; ADS_FRAME_BYTES];
                        for (d, s) in tx.iter_mut().zip(buf.iter()) {
                            *d = *s;
                        }
                        w.exchange(&tx, buf);
                    }
                    Operation::Write(tx) => w.exchange(tx, &mut []),
                    Operation::Read(rx) => w.exchange(&[], rx),
                    Operation::DelayNs(ns) => w.advance(u64::from(*ns)),
                }
            }
        });
        Ok(())
    }
}

//! Every clock of the board in one leaf module (it imports nothing from
//! the crate): the STM32F405's oscillators and bus clocks, what it gives the
//! ADS131M04 (CLKIN and the SPI clock), and the independent watchdog's LSI.
//! The drivers take these as arguments; the application and the bench read
//! them here.
//!
//! Sources: STM32F4 reference manual RM0090, STM32F405 datasheet DS8626,
//! ADS131M04 datasheet SBAS890.

/// The board's high-speed external crystal, Hz (RM0090 §6.2.1, HSE: a
/// 4–26 MHz crystal).
pub const BOARD_HSE_HZ: u32 = 8_000_000;

/// System clock the board runs at, Hz: the STM32F405's maximum (DS8626 §1,
/// "up to 168 MHz"), from the HSE through the main PLL (RM0090 §6.2.3).
pub const BOARD_SYSCLK_HZ: u32 = 168_000_000;

/// APB2, Hz: SYSCLK / 2, the bus's maximum (RM0090 §6.2, clock tree: APB2
/// at most 84 MHz). SPI1 hangs on it.
pub const BOARD_APB2_HZ: u32 = BOARD_SYSCLK_HZ / 2;

/// SysTick's input clock under QEMU, Hz: the emulated core's 168 MHz,
/// whatever RCC was asked for (QEMU does not model the clock tree).
pub const QEMU_SYSCLK_HZ: u32 = 168_000_000;

/// The ADC's SPI clock, Hz: APB2 / 4 = 21 MHz, under the ADS131M04's
/// 25 MHz (SBAS890 §6.6, t_c(SC) ≥ 40 ns).
pub const SPI_SCLK_HZ: u32 = BOARD_APB2_HZ / 4;
const _: () = assert!(SPI_SCLK_HZ <= 25_000_000, "the ADS131M04's SCLK is at most 25 MHz (SBAS890 §6.6)");

/// The ADC's CLKIN, Hz: the 8 MHz HSE on MCO1, PA8, undivided (RM0090
/// §6.2.10, clock-out capability), inside the ADS131M04's high-resolution
/// range (SBAS890 §6.3, 8.192 MHz nominal).
pub const ADC_CLKIN_HZ: u32 = BOARD_HSE_HZ;

/// LSI typical frequency, Hz (DS8626 §6.3.8, LSI oscillator
/// characteristics: f_LSI 17 / 32 / 47 kHz min / typ / max). The HAL sets
/// the independent watchdog's prescaler and reload for this.
pub const LSI_TYP_HZ: u32 = 32_000;

/// LSI fastest frequency, Hz (DS8626 §6.3.8, as [`LSI_TYP_HZ`]): the
/// watchdog's shortest real timeout.
pub const LSI_MAX_HZ: u32 = 47_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_derived_clocks_are_the_board_s_figures() {
        // 168 MHz / 2 = 84 MHz APB2 (RM0090's maximum), / 4 = 21 MHz SCLK,
        // under SBAS890's 25 MHz (a compile-time check above); CLKIN is the
        // 8 MHz crystal.
        assert_eq!(BOARD_APB2_HZ, 84_000_000);
        assert_eq!(SPI_SCLK_HZ, 21_000_000);
        assert_eq!(ADC_CLKIN_HZ, 8_000_000);
    }
}

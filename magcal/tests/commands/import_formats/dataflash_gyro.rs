//! `magcal import` of dataflash_gyro logs (being written).

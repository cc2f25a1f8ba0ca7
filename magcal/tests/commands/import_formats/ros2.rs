//! `magcal import` of ros2 logs (being written).

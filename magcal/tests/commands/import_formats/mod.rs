//! `magcal import` of each vehicle log format against its independent
//! reader (pymavlink, pyulog, rosbags, a decode from canboat's published
//! PGN definitions): counts and values from the reader's output committed
//! beside each fixture with the script that made it.

mod dataflash_gyro;
mod nmea2000;
mod ros2;
mod tlog;
mod ulog;

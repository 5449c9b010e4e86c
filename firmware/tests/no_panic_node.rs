//! Link-time proof that the node link cannot panic: the receiver of both ends
//! (`LinkDecoder::push`: COBS, CRC, version, postcard), the node's check and application of a
//! downlink (`Node::on_frame`: the ranges, the session, the replay check, the arm logic, the
//! outputs) and the topside's check of an uplink (`TopsideLink::on_frame`: the data checks,
//! the increments into an IMU sample). Optimized builds only:
//!
//! ```text
//! cargo test -p firmware --release --features no-panic --test no_panic_node
//! ```
//!
//! Without the feature this file is empty.
#![cfg(feature = "no-panic")]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use controller_core::nav::ImuSample;
use firmware::node::{Node, NodeConfig};
use firmware::node_link::{Downlink, LinkDecoder, LinkFrame, Uplink};
use firmware::topside_link::{NodeBridge, TopsideConfig, TopsideLink};
use firmware::{Monotonic, Sensors};
use std::convert::Infallible;
use std::hint::black_box;

struct Esc;
impl embedded_hal::pwm::ErrorType for Esc {
    type Error = Infallible;
}
impl embedded_hal::pwm::SetDutyCycle for Esc {
    fn max_duty_cycle(&self) -> u16 {
        20_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        black_box(duty);
        Ok(())
    }
}

struct Silent;
impl embedded_io::ErrorType for Silent {
    type Error = Infallible;
}
impl embedded_io::Read for Silent {
    fn read(&mut self, _: &mut [u8]) -> Result<usize, Infallible> {
        Ok(0)
    }
}
impl embedded_io::ReadReady for Silent {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(false)
    }
}
impl embedded_io::Write for Silent {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
impl embedded_io::WriteReady for Silent {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

struct Clock;
impl Monotonic for Clock {
    fn now_us(&mut self) -> u64 {
        black_box(0)
    }
}

struct NoImu;
impl Sensors for NoImu {
    fn imu(&mut self, _: u64) -> Option<ImuSample> {
        None
    }
    fn pressure_pa(&mut self, _: u64) -> Option<f32> {
        None
    }
}

#[test]
fn node_link_links_without_panics() {
    let mut down = LinkDecoder::<Downlink>::new();
    let mut up = LinkDecoder::<Uplink>::new();
    let mut node = Node::new([Esc, Esc, Esc], Silent, Clock, NoImu, NodeConfig::DEFAULT).unwrap();
    let bridge = NodeBridge::new(20_000);
    let mut link = TopsideLink::new(&bridge, Silent, TopsideConfig::new(1));
    for b in black_box([0u8, 3, 1, 2, 0, 9, 9, 9, 0]) {
        if let Some(f) = down.push(b) {
            assert!(node.on_frame(black_box(0), f).is_err());
        }
        if let Some(f) = up.push(b) {
            assert!(link.on_frame(black_box(0), f).is_err());
        }
    }
    assert!(node
        .on_frame(
            0,
            black_box(LinkFrame::Dropped(firmware::protocol::DropReason::Crc))
        )
        .is_err());
}

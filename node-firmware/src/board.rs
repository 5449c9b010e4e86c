//! The node image's board: the [`Node`] role on an emulated STM32F405 (QEMU
//! `netduinoplus2`), linked into the node budget (`memory-node.x`: 32 KiB of flash, 8 KiB of
//! RAM, an STM32G0 / F0-class part; a larger image fails to link).
//!
//! - ESCs: TIM3 CH1/CH2/CH3 on PA6/PA7/PB0, 50 Hz, 1 us resolution (as the onboard image);
//! - the node link: USART1 (PA9/PA10, QEMU `-serial` 0) at 115,200 Bd, the interrupt-driven
//!   port of [`firmware::board::Tether`];
//! - clock: TIM2 at prescaler 0 on the default 16 MHz clock (QEMU does not model the RCC), so
//!   one tick per instruction under `-icount shift=0` and 16 ticks a microsecond;
//! - sensors: none on the emulated board ([`NoSensors`]: the IMU and the pressure are
//!   reported lost, `IMU_LOST` / `PRESSURE_LOST`); on a real node the ICM-42688-P and the
//!   MS5837-30BA through [`firmware::BusSensors`], as the onboard image wires them;
//! - the DVL: a Water Linked A50 on USART2 (PA2 / PA3, QEMU `-serial` 1) at 115,200 Bd, into
//!   the onboard images' interrupt-driven 512-byte ring ([`firmware::board::dvl_uart`]),
//!   parsed and gated by the same [`DvlPort`], 64 bytes and one line a pass at most (a pass
//!   is 2.5 ms: 29 bytes arrive in it at most), never in the pass that seals an uplink.
//!
//! With the `node-bench` feature the image does not serve the link: it runs the node for
//! 2 s of virtual time with a synthetic IMU, a downlink frame every link period through
//! a RAM port and the DVL's `wrz` lines at 15 Hz arriving at the wire's rate, counts the
//! instructions of each pass on TIM2 and prints them over semihosting
//! (`scripts/mcu-cost.sh`), with the stack it used (painting).
#![allow(unsafe_code)]

use firmware::board::Tim2Clock;
use firmware::node::{Node, NodeConfig};
use firmware::sensors::dvl::DvlPort;
use firmware::Monotonic;
#[cfg(not(feature = "node-bench"))]
use firmware::{
    board::dvl_uart::{start_dvl_uart, DVL_US_PER_BYTE},
    board::Tether,
    sensors::dvl::{a50::VelocityGate, WithDvl},
    NoSensors, Sensors,
};
use stm32f4xx_hal::{
    pac::{self, TIM3},
    prelude::*,
    timer::ErasedChannel,
    watchdog::IndependentWatchdog,
};

/// An ESC output.
type Pwm = ErasedChannel<TIM3>;

/// Watchdog timeout of the node, milliseconds: a stuck loop resets it, and it boots neutral.
pub const WATCHDOG_MS: u32 = 100;

/// DVL bytes taken a pass at most: twice what the wire brings in a 2.5 ms pass (29 at
/// 115,200 Bd), so the port keeps up and one pass stays short.
pub const DVL_BYTES_PER_PASS: usize = 64;

/// The node's DVL port: 64 bytes and one line (one parse) a pass at most.
pub fn node_dvl_port<U>(port: DvlPort<U>) -> DvlPort<U>
where
    U: embedded_io::Read + embedded_io::ReadReady,
{
    port.with_poll_limits(DVL_BYTES_PER_PASS, 1)
}

fn halt() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Bring the node up and run it forever (or, with `node-bench`, measure it and exit).
pub fn run() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        halt()
    };
    let mut rcc = dp.RCC.constrain();
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let config = NodeConfig::DEFAULT;
    let (_pwm, (ch1, ch2, ch3, _)) = dp.TIM3.pwm_us(config.pwm_period_us.micros(), &mut rcc);
    let pwm: [Pwm; 3] = [
        ch1.with(gpioa.pa6).erase(),
        ch2.with(gpioa.pa7).erase(),
        ch3.with(gpiob.pb0).erase(),
    ];
    let clock = Tim2Clock::start(dp.TIM2.counter::<16_000_000>(&mut rcc));
    #[cfg(feature = "node-bench")]
    {
        let _ = (dp.USART1, gpioa.pa9, gpioa.pa10, dp.USART2);
        bench::run(pwm, clock, watchdog)
    }
    #[cfg(not(feature = "node-bench"))]
    {
        let tether = firmware::board::start_tether(dp.USART1, (gpioa.pa9, gpioa.pa10), &mut rcc);
        let (dvl_uart, dvl_ok) = start_dvl_uart(dp.USART2, (gpioa.pa2, gpioa.pa3), &mut rcc);
        defmt::info!("DVL port {}", dvl_ok);
        let sensors = WithDvl {
            inner: NoSensors,
            dvl: node_dvl_port(DvlPort::new(
                dvl_uart,
                VelocityGate::default(),
                DVL_US_PER_BYTE,
            )),
        };
        serve(pwm, tether, clock, sensors, watchdog)
    }
}

/// The node's loop: neutral on the outputs before they are enabled, then tick forever.
#[cfg(not(feature = "node-bench"))]
fn serve<C: Monotonic, N: Sensors>(
    pwm: [Pwm; 3],
    tether: Tether,
    clock: C,
    sensors: N,
    mut watchdog: IndependentWatchdog,
) -> ! {
    let mut node = match Node::new(pwm, tether, clock, sensors, NodeConfig::DEFAULT) {
        Ok(n) => n,
        Err(_) => halt(),
    };
    // Neutral is written (by `Node::new`); now the outputs may drive the ESCs.
    node.parts_mut().0.iter_mut().for_each(Pwm::enable);
    defmt::info!("node ready: neutral, disarmed, latched");
    let mut armed = false;
    loop {
        node.tick();
        watchdog.feed();
        if node.armed() != armed {
            armed = node.armed();
            let c = node.counters();
            defmt::info!(
                "node armed {} session {=u32:#x} accepted {} refused {}",
                armed,
                node.session(),
                c.accepted,
                c.corrupt
                    .wrapping_add(c.replayed)
                    .wrapping_add(c.out_of_range)
                    .wrapping_add(c.foreign)
                    .wrapping_add(c.version)
            );
        }
    }
}

#[cfg(feature = "node-bench")]
mod bench {
    //! Instructions per node pass, under `-icount shift=0` (one TIM2 tick an instruction).
    use super::*;
    use core::cell::Cell;
    use core::ptr::{addr_of, read_volatile, write_volatile};
    use cortex_m_semihosting::{debug, hio};
    use firmware::node_link::{seal, ArmCommand, Downlink, ESC_NEUTRAL_US};
    use firmware::protocol::MAX_FRAME_LEN;
    use firmware::sensors::dvl::{a50, a50::VelocityGate, WithDvl};
    use firmware::sensors::ImuSample;
    use firmware::Sensors;
    use heapless::Deque;

    /// Virtual time of the bench, microseconds.
    struct VirtualClock<'a>(&'a Cell<u64>);

    impl Monotonic for VirtualClock<'_> {
        fn now_us(&mut self) -> u64 {
            self.0.get()
        }
    }

    /// A port in RAM: the bench queues the bytes the wire brings (`N` of them at most); what
    /// the node writes is discarded. The node link's port and the DVL's UART.
    struct RamPort<'a, const N: usize>(&'a core::cell::RefCell<Deque<u8, N>>);

    impl<const N: usize> embedded_io::ErrorType for RamPort<'_, N> {
        type Error = core::convert::Infallible;
    }
    impl<const N: usize> embedded_io::Read for RamPort<'_, N> {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
            let Ok(mut q) = self.0.try_borrow_mut() else {
                return Ok(0);
            };
            let mut n = 0;
            for b in buf.iter_mut() {
                let Some(x) = q.pop_front() else { break };
                *b = x;
                n += 1;
            }
            Ok(n)
        }
    }
    impl<const N: usize> embedded_io::ReadReady for RamPort<'_, N> {
        fn read_ready(&mut self) -> Result<bool, Self::Error> {
            Ok(self.0.try_borrow().is_ok_and(|q| !q.is_empty()))
        }
    }
    impl<const N: usize> embedded_io::Write for RamPort<'_, N> {
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            Ok(buf.len())
        }
        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }
    impl<const N: usize> embedded_io::WriteReady for RamPort<'_, N> {
        fn write_ready(&mut self) -> Result<bool, Self::Error> {
            Ok(true)
        }
    }

    /// A line under construction (no `core::fmt`: it would not fit the node's budget).
    struct LineBuf(heapless::Vec<u8, 200>);

    impl LineBuf {
        #[inline(never)]
        fn text(&mut self, s: &[u8]) {
            let _ = self.0.extend_from_slice(s);
        }
        /// `v` in decimal, at least `width` digits (leading zeros).
        #[inline(never)]
        fn num(&mut self, v: u64, width: usize) {
            let mut d = [b'0'; 20];
            let (mut v, mut i) = (v, d.len());
            while v > 0 || d.len() - i < width {
                i -= 1;
                if let Some(b) = d.get_mut(i) {
                    *b = b'0' + (v % 10) as u8;
                }
                v /= 10;
            }
            self.text(d.get(i..).unwrap_or_default());
        }
    }

    /// A `wrz` line as host-sim's DVL prints it (a full covariance; the velocities and the
    /// figure of merit changing with `i`), its CRC-8 and CR LF.
    #[inline(never)]
    fn wrz_line(i: u32, t_us: u64) -> heapless::Vec<u8, 200> {
        let mut l = LineBuf(heapless::Vec::new());
        let k = u64::from(i % 97);
        let fom_mm = 5 + u64::from(i % 7);
        let tov = 1_767_225_600_000_000 + t_us;
        l.text(b"wrz,0.");
        l.num(k % 5, 3);
        l.text(b",-0.");
        l.num(k % 3, 3);
        l.text(b",0.000,y,3.");
        l.num(20 + k % 50, 2);
        l.text(b",0.");
        l.num(fom_mm, 3);
        for c in 0..9 {
            l.text(if c == 0 { b"," } else { b";" });
            if c % 4 == 0 {
                l.num(fom_mm * fom_mm / 10, 1);
                l.text(b"e-5");
            } else {
                l.text(b"0");
            }
        }
        for _ in 0..2 {
            l.text(b",");
            l.num(tov, 1);
        }
        l.text(b",100.00,0");
        let crc = a50::CRC8.checksum(&l.0);
        let hex = |n: u8| if n < 10 { b'0' + n } else { b'a' + n - 10 };
        l.text(&[b'*', hex(crc >> 4), hex(crc & 0xf), b'\r', b'\n']);
        l.0
    }

    /// The next bytes of `line` from `at` that the wire brings in a pass (29) into the
    /// DVL's UART; how many.
    #[inline(never)]
    fn feed_dvl(line: &[u8], at: usize, q: &core::cell::RefCell<Deque<u8, 256>>) -> usize {
        let (Some(bytes), Ok(mut q)) =
            (line.get(at..(at + 29).min(line.len())), q.try_borrow_mut())
        else {
            return 0;
        };
        for &b in bytes {
            let _ = q.push_back(b);
        }
        bytes.len()
    }

    /// A moving IMU (so the sums are not constant) and a pressure every call.
    struct SyntheticImu(u32);

    impl Sensors for SyntheticImu {
        fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
            self.0 = self.0.wrapping_add(1);
            let k = (self.0 % 64) as f32 * 1e-3;
            Some(ImuSample {
                t_us: now_us,
                gyro_rad_s: [k, -k, 0.5 * k],
                accel_m_s2: [k, 0.1, -9.81 + k],
            })
        }
        fn pressure_pa(&mut self, _now_us: u64) -> Option<f32> {
            Some(120_000.0 + (self.0 % 16) as f32)
        }
    }

    /// Mean and max of one kind of pass.
    #[derive(Default)]
    struct Stat {
        n: u32,
        sum: u64,
        max: u32,
    }

    impl Stat {
        #[inline(never)]
        fn add(&mut self, v: u32) {
            self.n += 1;
            self.sum += u64::from(v);
            self.max = self.max.max(v);
        }
        fn mean(&self) -> u32 {
            (self.sum / u64::from(self.n.max(1))) as u32
        }
    }

    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    const PAINT: u32 = 0xDEAD_BEEF;

    /// Paint the free stack below the current frame (leaving 64 bytes).
    #[inline(never)]
    fn paint_stack() {
        let sp = cortex_m::register::msp::read() as usize - 64;
        let mut p = addr_of!(_stack_end) as usize;
        while p < sp {
            // SAFETY: words between the end of .bss (_stack_end) and below the live stack
            // pointer are free stack, owned by nobody; aligned (cortex-m-rt aligns both).
            unsafe { write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
    }

    /// Bytes of stack ever used (from the top of RAM to the lowest overwritten word).
    fn stack_used() -> u32 {
        let top = addr_of!(_stack_start) as usize;
        let mut p = addr_of!(_stack_end) as usize;
        // SAFETY: reads of the free stack area painted above.
        while p < top && unsafe { read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        (top - p) as u32
    }

    #[inline(never)]
    fn print(parts: &[&[u8]]) {
        if let Ok(mut out) = hio::hstdout() {
            for p in parts {
                let _ = out.write_all(p);
            }
            let _ = out.write_all(b"\n");
        }
    }

    /// `v` in decimal into `buf`.
    #[inline(never)]
    fn dec(v: u32, buf: &mut [u8; 10]) -> &[u8] {
        let mut i = buf.len();
        let mut v = v;
        loop {
            i -= 1;
            if let Some(b) = buf.get_mut(i) {
                *b = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || i == 0 {
                break;
            }
        }
        buf.get(i..).unwrap_or_default()
    }

    fn report(name: &[u8], s: &Stat) {
        let (mut a, mut b, mut c) = ([0; 10], [0; 10], [0; 10]);
        print(&[
            b"BENCH ",
            name,
            b" mean=",
            dec(s.mean(), &mut a),
            b" max=",
            dec(s.max, &mut b),
            b" n=",
            dec(s.n, &mut c),
        ]);
    }

    pub(super) fn run(
        pwm: [Pwm; 3],
        mut tim2: Tim2Clock<16_000_000>,
        _wd: IndependentWatchdog,
    ) -> ! {
        paint_stack();
        let t = Cell::new(0u64);
        let q = core::cell::RefCell::new(Deque::<u8, 64>::new());
        let dvl_q = core::cell::RefCell::new(Deque::<u8, 256>::new());
        let sensors = WithDvl {
            inner: SyntheticImu(0),
            dvl: node_dvl_port(DvlPort::new(RamPort(&dvl_q), VelocityGate::default(), 87)),
        };
        let Ok(mut node) = Node::new(
            pwm,
            RamPort(&q),
            VirtualClock(&t),
            sensors,
            NodeConfig::DEFAULT,
        ) else {
            halt()
        };
        let overhead = {
            let a = tim2.ticks();
            let b = tim2.ticks();
            b.wrapping_sub(a)
        };
        let (mut imu, mut down, mut up, mut all, mut dvl_line) = (
            Stat::default(),
            Stat::default(),
            Stat::default(),
            Stat::default(),
            Stat::default(),
        );
        // The DVL: a `wrz` line every 26 passes (65 ms: 15.4 Hz, the A50's fastest), its
        // bytes arriving at the wire's rate, 29 a pass (115,200 Bd over 2.5 ms).
        let mut line = wrz_line(0, 0);
        let mut line_at = line.len();
        let mut lines = 0u32;
        let cfg = NodeConfig::DEFAULT;
        let per_link = cfg.link_period_us / cfg.imu_period_us;
        let mut frame = [0u8; MAX_FRAME_LEN];
        let mut seq = 0u16;
        for pass in 0..(2_000_000 / cfg.imu_period_us) {
            t.set(u64::from(pass) * u64::from(cfg.imu_period_us) + 1);
            // A downlink every link period, half a period away from the uplink, and every
            // fourth one on the uplink's pass (the worst pass: IMU, frame in, frame out).
            let phase = pass % per_link;
            let frame_now = phase == per_link / 2 || (phase == 0 && pass % (4 * per_link) == 0);
            if frame_now {
                seq = seq.wrapping_add(1);
                let arm = if seq < 3 {
                    ArmCommand::Disarmed
                } else {
                    ArmCommand::Armed
                };
                let k = seq % 200;
                let cmd = Downlink {
                    session: 0x5EED,
                    seq: u64::from(seq),
                    pulse_us: [
                        ESC_NEUTRAL_US + k,
                        ESC_NEUTRAL_US - k,
                        ESC_NEUTRAL_US + k / 2,
                    ],
                    ttl_ms: 100,
                    arm,
                    t_us: 0,
                };
                if let (Ok(f), Ok(mut q)) = (seal(seq, &cmd, &mut frame), q.try_borrow_mut()) {
                    for &b in f {
                        let _ = q.push_back(b);
                    }
                }
            }
            if pass % 26 == 3 {
                lines += 1;
                line = wrz_line(lines, u64::from(pass) * u64::from(cfg.imu_period_us));
                line_at = 0;
            }
            line_at += feed_dvl(&line, line_at, &dvl_q);
            let judged = |n: &mut Node<_, _, _, WithDvl<_, _>>| {
                let s = n.parts_mut().3.dvl.stats();
                s.accepted.wrapping_add(s.refused()).wrapping_add(s.other)
            };
            let before = judged(&mut node);
            let t0 = tim2.ticks();
            node.tick();
            let dt = tim2.ticks().wrapping_sub(t0).saturating_sub(overhead);
            let line_ended = judged(&mut node) != before;
            all.add(dt);
            match (frame_now, phase == 0 && pass > 0, line_ended) {
                (_, _, true) => dvl_line.add(dt),
                (false, false, false) => imu.add(dt),
                (true, false, false) => down.add(dt),
                (_, true, false) => up.add(dt),
            }
        }
        report(b"node.imu_pass", &imu);
        report(b"node.imu_pass_downlink", &down);
        report(b"node.imu_pass_uplink", &up);
        report(b"node.imu_pass_dvl_line", &dvl_line);
        report(b"node.pass_all", &all);
        let (mut a, mut b, mut c, mut d) = ([0; 10], [0; 10], [0; 10], [0; 10]);
        let dvl = node.parts_mut().3.dvl.stats();
        print(&[
            b"NODE armed=",
            if node.armed() { b"1" } else { b"0" },
            b" accepted=",
            dec(u32::from(node.counters().accepted), &mut a),
            b" dvl_accepted=",
            dec(dvl.accepted, &mut c),
            b" dvl_refused=",
            dec(dvl.refused(), &mut d),
            b" stack=",
            dec(stack_used(), &mut b),
        ]);
        debug::exit(debug::EXIT_SUCCESS);
        loop {
            cortex_m::asm::bkpt();
        }
    }
}

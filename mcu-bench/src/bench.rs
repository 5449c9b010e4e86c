//! The measurements, independent of where they run.
//!
//! Every item is timed call by call: read the counter, call an `#[inline(never)]` function on
//! an input that changes every call, read the counter again, subtract the cost of reading the
//! counter (calibrated at start). Inputs are made between two timed calls, outside the timed
//! region. On the emulated MCU the counter is TIM2 under `-icount shift=0`, i.e. exactly one
//! tick per guest instruction; on the host it is nanoseconds (a smoke run only).
//!
//! Output lines start with `BENCH` (one per item) so `scripts/mcu-cost.sh` can pick them out:
//! `BENCH <name> calls=<n> mean=<x.y> min=<n> max=<n> stack=<bytes>`.

use crate::plant::{Plane, Plant};
use controller_core::alloc::{allocate, PwmMap, ThrusterLimits};
use controller_core::controller::{ControlMode, Controller, Gains};
#[cfg(feature = "law-alone")]
use controller_core::law::tracking::{self, TrackingState};
#[cfg(feature = "law-alone")]
use controller_core::law::{paper_xy, paper_xz};
use controller_core::math;
use controller_core::params::Vehicle;
use controller_core::reference::{PaperPolynomial, RefSample, Reference};
use controller_core::state::{BodyForces, NavState};
use core::fmt;
use core::hint::black_box;
use core::sync::atomic::{compiler_fence, Ordering};

/// Calls per item (each with a different input).
pub const CALLS: u32 = 512;

/// Build-time filter for profiling (`scripts/mcu-profile.sh`): when set, only the items whose
/// name starts with it run.
const ONLY: Option<&str> = option_env!("MCU_BENCH_ONLY");

/// The timed call. In a profiling build (`MCU_BENCH_ONLY` set) it goes through the
/// `#[inline(never)]` [`timed`], which `scripts/mcu-profile.py` finds in the trace; otherwise
/// it is inlined and the count holds only the measured code.
#[inline(always)]
fn call<R>(f: impl FnOnce() -> R) -> R {
    if ONLY.is_some() {
        timed(f)
    } else {
        f()
    }
}

#[inline(never)]
fn timed<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Control period used for the tracking laws' integrators (50 Hz).
const DT_S: f32 = 0.02;

/// What the bench needs from where it runs.
pub trait Platform {
    /// Free-running counter (instructions on the MCU).
    fn now(&self) -> u32;
    /// Print one line.
    fn print(&self, args: fmt::Arguments<'_>);
    /// Fill the free stack below the caller with a pattern.
    fn paint_stack(&self);
    /// Bytes of stack touched below the point of the last [`Platform::paint_stack`], if known.
    fn stack_used_since_paint(&self) -> Option<u32>;
    /// Bytes of stack touched since reset (from the top of RAM), if known.
    fn stack_high_water(&self) -> Option<u32>;
    /// Square root by the FPU's `VSQRT.F32`, where there is one (a proposal for the core:
    /// `libm::sqrtf` is integer code on this target).
    fn hw_sqrt(&self, _x: f32) -> Option<f32> {
        None
    }
}

/// Running statistics of one item.
#[derive(Clone, Copy)]
struct Stats {
    calls: u32,
    sum: u64,
    min: u32,
    max: u32,
    /// Index of the (first) call that took `max`.
    max_at: u32,
    /// The largest excluding the first call (a start: filters and solvers initialised).
    max_after_first: u32,
}

impl Stats {
    const fn new() -> Self {
        Self {
            calls: 0,
            sum: 0,
            min: u32::MAX,
            max: 0,
            max_at: 0,
            max_after_first: 0,
        }
    }

    fn add(&mut self, ticks: u32) {
        if ticks > self.max {
            self.max_at = self.calls;
        }
        if self.calls > 0 {
            self.max_after_first = self.max_after_first.max(ticks);
        }
        self.calls += 1;
        self.sum += u64::from(ticks);
        self.min = self.min.min(ticks);
        self.max = self.max.max(ticks);
    }

    /// Mean in tenths of a tick (integer maths: no float formatting on the target).
    fn mean_tenths(&self) -> u64 {
        if self.calls == 0 {
            0
        } else {
            (self.sum * 10 + u64::from(self.calls) / 2) / u64::from(self.calls)
        }
    }
}

/// Small deterministic generator for varying inputs (no float maths beyond a conversion).
struct Lcg(u32);

impl Lcg {
    /// Uniform in [-1, 1).
    fn next_sym(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((self.0 >> 8) as f32) * (1.0 / 8_388_608.0) - 1.0
    }
}

/// The timing harness: counter, counter cost, printing.
pub struct Bench<'a, P: Platform> {
    p: &'a P,
    overhead: u32,
}

impl<'a, P: Platform> Bench<'a, P> {
    /// Calibrate the cost of two back-to-back counter reads.
    pub fn new(p: &'a P) -> Self {
        let mut overhead = u32::MAX;
        for _ in 0..16 {
            compiler_fence(Ordering::SeqCst);
            let t0 = p.now();
            compiler_fence(Ordering::SeqCst);
            let t1 = p.now();
            compiler_fence(Ordering::SeqCst);
            overhead = overhead.min(t1.wrapping_sub(t0));
        }
        Self { p, overhead }
    }

    /// Time `f(&input)`, inputs from `make(i)` for `i in 0..calls`, and print one line.
    pub fn run<I, O>(
        &self,
        name: &str,
        calls: u32,
        mut make: impl FnMut(u32) -> I,
        mut f: impl FnMut(&I) -> O,
    ) -> u64 {
        if let Some(only) = ONLY {
            if !name.starts_with(only) {
                return 0;
            }
        }
        let mut st = Stats::new();
        self.p.paint_stack();
        for i in 0..calls {
            let input = make(i);
            // Only the address goes through `black_box`: the input is in memory before the
            // first counter read, and the timed region holds just the call.
            let input = black_box(&input);
            compiler_fence(Ordering::SeqCst);
            let t0 = self.p.now();
            compiler_fence(Ordering::SeqCst);
            let out = call(|| f(input));
            let _ = black_box(&out);
            compiler_fence(Ordering::SeqCst);
            let t1 = self.p.now();
            compiler_fence(Ordering::SeqCst);
            st.add(t1.wrapping_sub(t0).saturating_sub(self.overhead));
        }
        self.report(name, &st)
    }

    fn report(&self, name: &str, st: &Stats) -> u64 {
        let stack = self.p.stack_used_since_paint();
        let mean = st.mean_tenths();
        match stack {
            Some(s) => self.p.print(format_args!(
                "BENCH {name} calls={} mean={}.{} min={} max={} stack={s} max_at={} max_after_first={}",
                st.calls,
                mean / 10,
                mean % 10,
                st.min,
                st.max,
                st.max_at,
                st.max_after_first
            )),
            None => self.p.print(format_args!(
                "BENCH {name} calls={} mean={}.{} min={} max={} stack=n/a max_at={} max_after_first={}",
                st.calls,
                mean / 10,
                mean % 10,
                st.min,
                st.max,
                st.max_at,
                st.max_after_first
            )),
        }
        mean
    }
}

impl<P: Platform> Bench<'_, P> {
    /// Like [`Bench::run`], for an item that works on one state: `prepare(state, i)` before
    /// each timed `f(state)`, `check(state)` after it (both untimed).
    pub fn run_state<S>(
        &self,
        name: &str,
        calls: u32,
        state: &mut S,
        mut prepare: impl FnMut(&mut S, u32),
        mut f: impl FnMut(&mut S),
        mut check: impl FnMut(&mut S),
    ) -> u64 {
        let mut st = Stats::new();
        if let Some(only) = ONLY {
            if !name.starts_with(only) {
                return 0;
            }
        }
        self.p.paint_stack();
        for i in 0..calls {
            prepare(state, i);
            let s = black_box(&mut *state);
            compiler_fence(Ordering::SeqCst);
            let t0 = self.p.now();
            compiler_fence(Ordering::SeqCst);
            call(|| f(s));
            compiler_fence(Ordering::SeqCst);
            let t1 = self.p.now();
            compiler_fence(Ordering::SeqCst);
            st.add(t1.wrapping_sub(t0).saturating_sub(self.overhead));
            check(state);
        }
        self.report(name, &st)
    }
}

/// Angles spread over [-10, 10] rad.
fn angle(i: u32, g: &mut Lcg) -> f32 {
    let _ = i;
    10.0 * g.next_sym()
}

#[inline(never)]
fn own_sin_cos(x: f32) -> (f32, f32) {
    math::sin_cos(x)
}

#[cfg(feature = "libm-compare")]
#[inline(never)]
fn libm_sinf(x: f32) -> f32 {
    libm::sinf(x)
}

#[cfg(feature = "libm-compare")]
#[inline(never)]
fn micromath_sin(x: f32) -> f32 {
    micromath::F32Ext::sin(x)
}

#[inline(never)]
fn own_atan2(a: (f32, f32)) -> f32 {
    math::atan2(a.0, a.1)
}

#[inline(never)]
fn own_sqrt(x: f32) -> f32 {
    math::sqrt(x)
}

#[inline(never)]
fn ref_sample(a: (&Reference, f32)) -> RefSample {
    a.0.sample(a.1)
}

#[inline(never)]
fn alloc_pwm(a: (&BodyForces, &ThrusterLimits, &PwmMap)) -> [f32; 3] {
    let al = allocate(a.0, a.1);
    [
        a.2.pulse_us(al.thrust_n[0]),
        a.2.pulse_us(al.thrust_n[1]),
        a.2.pulse_us(al.thrust_n[2]),
    ]
}

#[inline(never)]
fn control_step(c: &mut Controller, mode: ControlMode, nav: &NavState, r: &RefSample) -> [f32; 3] {
    c.step(mode, nav, r, DT_S).pulse_us
}

/// The state of one closed-loop bench item.
struct ClosedLoop<'a> {
    ctl: &'a mut Controller,
    plant: Plant,
    reference: RefSample,
    /// The forces the last step's thrusters made.
    out: BodyForces,
}

/// The state of one law-alone bench item.
#[cfg(feature = "law-alone")]
struct LawLoop {
    plant: Plant,
    state: TrackingState,
    reference: RefSample,
    forces: BodyForces,
}

/// The law of `mode` alone, as `Controller::step` runs it.
#[cfg(feature = "law-alone")]
fn law_step(v: &Vehicle, g: &Gains, mode: ControlMode, s: &mut LawLoop) -> BodyForces {
    let nav = s.plant.nav();
    let r = &s.reference;
    let st = &mut s.state;
    let t = &g.tracking;
    let out = match mode {
        ControlMode::PaperXz => paper_xz::step(v, &g.paper_xz, &nav.xz(), r),
        ControlMode::PaperXy => paper_xy::step(v, &g.paper_xy, &nav.xy(), r),
        ControlMode::TrackingXz => tracking::step_xz(v, t, st, nav, r, DT_S),
        ControlMode::TrackingXy => tracking::step_xy(v, t, st, nav, r, DT_S),
        ControlMode::Tracking3d => tracking::step_3d(v, t, st, nav, r, DT_S),
    };
    out.forces
}

/// A start off the reference at `r`: 0.3 m along x, -0.2 m along y, 0.2 m deep, 0.2 rad of
/// yaw, 0.1 m/s slower, so the laws work through a transient before they track.
pub(crate) fn offset_start(r: &RefSample) -> NavState {
    let [x, y, z] = r.pos_m;
    let [vx, vy, _] = r.vel_m_s;
    NavState {
        x_m: x + 0.3,
        y_m: y - 0.2,
        z_m: z + 0.2,
        yaw_rad: math::atan2(vy, vx) + 0.2,
        u_m_s: math::sqrt(vx * vx + vy * vy) - 0.1,
        ..NavState::default()
    }
}

/// A navigation state near the reference at `t`: within about half a metre, 0.3 rad and
/// 0.2 m/s of it, so the laws run in their working regime, sometimes saturating.
fn nav_near(r: &RefSample, g: &mut Lcg) -> NavState {
    let [x, y, z] = r.pos_m;
    let [vx, vy, vz] = r.vel_m_s;
    NavState {
        x_m: x + 0.5 * g.next_sym(),
        y_m: y + 0.5 * g.next_sym(),
        z_m: z + 0.5 * g.next_sym(),
        roll_rad: 0.05 * g.next_sym(),
        pitch_rad: 0.3 * g.next_sym(),
        yaw_rad: math::atan2(vy, vx) + 0.3 * g.next_sym(),
        u_m_s: vx + 0.2 * g.next_sym(),
        v_m_s: 0.1 * g.next_sym(),
        w_m_s: vz + 0.1 * g.next_sym(),
        p_rad_s: 0.05 * g.next_sym(),
        q_rad_s: 0.1 * g.next_sym(),
        r_rad_s: 0.1 * g.next_sym(),
    }
}

/// The references the loop can follow, one of each kind.
pub fn references() -> [(&'static str, Reference); 4] {
    [
        ("paper", Reference::Paper(PaperPolynomial::PAPER)),
        (
            "circle",
            Reference::Circle {
                center_m: [0.0, 0.0, 2.0],
                radius_m: 5.0,
                speed_m_s: 0.5,
            },
        ),
        (
            "lawnmower",
            Reference::Lawnmower {
                start_m: [0.0, 0.0, 2.0],
                heading_rad: 0.0,
                leg_length_m: 20.0,
                spacing_m: 4.0,
                legs: 6,
                speed_m_s: 0.5,
            },
        ),
        (
            "helix",
            Reference::Helix {
                center_m: [0.0, 0.0, 1.0],
                radius_m: 5.0,
                speed_m_s: 0.5,
                depth_rate_m_s: 0.05,
            },
        ),
    ]
}

/// All modes of the controller, with their names.
pub const MODES: [(&str, ControlMode); 5] = [
    ("paper_xz", ControlMode::PaperXz),
    ("paper_xy", ControlMode::PaperXy),
    ("tracking_xz", ControlMode::TrackingXz),
    ("tracking_xy", ControlMode::TrackingXy),
    ("tracking_3d", ControlMode::Tracking3d),
];

/// The counter overhead subtracted from every figure.
impl<P: Platform> Bench<'_, P> {
    /// Ticks of two back-to-back counter reads.
    pub fn overhead(&self) -> u32 {
        self.overhead
    }
}

/// The maths, the control steps and the laws. Returns false if the controller could not be
/// built.
pub fn run_core<P: Platform>(b: &Bench<'_, P>, p: &P) -> bool {
    // Maths.
    let mut g = Lcg(1);
    b.run(
        "math.sin_cos",
        CALLS,
        |i| angle(i, &mut g),
        |x| own_sin_cos(*x),
    );
    #[cfg(feature = "libm-compare")]
    {
        let mut g = Lcg(1);
        b.run("libm.sinf", CALLS, |i| angle(i, &mut g), |x| libm_sinf(*x));
        let mut g = Lcg(1);
        b.run(
            "micromath.sin",
            CALLS,
            |i| angle(i, &mut g),
            |x| micromath_sin(*x),
        );
        // Accuracy of both f32 sines against libm's (f64 inside, correctly rounded in
        // practice), over 8,192 angles in [-10, 10] rad.
        let mut g = Lcg(7);
        let (mut own, mut mm) = (0.0f32, 0.0f32);
        for i in 0..8192 {
            let x = angle(i, &mut g);
            let r = libm::sinf(x);
            own = math::max(own, (own_sin_cos(x).0 - r).abs());
            mm = math::max(mm, (micromath_sin(x) - r).abs());
        }
        p.print(format_args!(
            "ACCURACY sin max_abs_err vs libm::sinf over 8192 angles in [-10, 10] rad: \
             math::sin_cos {own:e}, micromath {mm:e}"
        ));
    }
    let mut g = Lcg(2);
    b.run(
        "math.atan2",
        CALLS,
        |_| (5.0 * g.next_sym(), 5.0 * g.next_sym()),
        |a| own_atan2(*a),
    );
    let mut g = Lcg(3);
    b.run(
        "math.sqrt",
        CALLS,
        |_| 50.0 * (g.next_sym() + 1.0),
        |x| own_sqrt(*x),
    );

    if p.hw_sqrt(1.0).is_some() {
        let mut g = Lcg(3);
        b.run(
            "proposal.vsqrt",
            CALLS,
            |_| 50.0 * (g.next_sym() + 1.0),
            |x| p.hw_sqrt(*x),
        );
    }

    // References (t over 0..100 s).
    for (name, r) in references().iter() {
        let mut buf = [0u8; 40];
        let label = join(&mut buf, "reference.", name);
        b.run(
            label,
            CALLS,
            |i| i as f32 * (100.0 / CALLS as f32),
            |t| ref_sample((r, *t)),
        );
    }

    let vehicle = Vehicle::observer();
    let Ok(mut ctl) = Controller::new(vehicle, Gains::default()) else {
        p.print(format_args!("mcu-bench: Controller::new failed"));
        return false;
    };

    // Allocation + PWM map alone.
    let limits = *ctl.limits();
    let pwm = *ctl.pwm_map();
    let mut g = Lcg(4);
    b.run(
        "alloc+pwm",
        CALLS,
        |_| BodyForces {
            surge_n: 60.0 * g.next_sym(),
            yaw_n_m: 10.0 * g.next_sym(),
            heave_n: 40.0 * g.next_sym(),
        },
        |f| alloc_pwm((f, &limits, &pwm)),
    );

    // Control step (law + allocation + PWM) for every mode, following the paper reference
    // (XZ modes and the paper XY law) or the circle (tracking XY and 3-D).
    let paper = Reference::Paper(PaperPolynomial::PAPER);
    let circle = Reference::Circle {
        center_m: [0.0, 0.0, 2.0],
        radius_m: 5.0,
        speed_m_s: 0.5,
    };
    let ref_for = |mode: &ControlMode| match mode {
        ControlMode::PaperXz | ControlMode::TrackingXz | ControlMode::PaperXy => paper,
        ControlMode::TrackingXy | ControlMode::Tracking3d => circle,
    };

    // In closed loop (the figures the targets are judged on): the controller steers the
    // core's planar model of the vehicle (`crate::plant`, untimed between the steps) from an
    // offset start, one control period per call, as in operation. The first call is the
    // cold start of the laws' filters and solvers.
    for (name, mode) in MODES.iter() {
        let r = ref_for(mode);
        ctl.reset();
        let plane = Plane::for_mode(*mode);
        let mut sim = ClosedLoop {
            ctl: &mut ctl,
            plant: Plant::new(vehicle, plane, offset_start(&r.sample(0.0))),
            reference: RefSample::default(),
            out: BodyForces::default(),
        };
        let mut buf = [0u8; 40];
        let label = join(&mut buf, "control_step.", name);
        b.run_state(
            label,
            CALLS,
            &mut sim,
            |s, i| s.reference = r.sample(i as f32 * DT_S),
            |s| {
                let out = s.ctl.step(*mode, s.plant.nav(), &s.reference, DT_S);
                s.out = out.allocation.achieved;
            },
            |s| {
                let f = s.out;
                s.plant.advance(&f, DT_S);
            },
        );
        // What the loop did: the origin's distance from the reference at the end.
        let n = sim.plant.nav();
        let [x, y, z] = r.sample(CALLS as f32 * DT_S).pos_m;
        let (ex, ey, ez) = (n.x_m - x, n.y_m - y, n.z_m - z);
        let err = match plane {
            Plane::Xz => math::sqrt(ex * ex + ez * ez),
            Plane::Xy3d if *mode == ControlMode::Tracking3d => {
                math::sqrt(ex * ex + ey * ey + ez * ez)
            }
            Plane::Xy3d => math::sqrt(ex * ex + ey * ey),
        };
        p.print(format_args!(
            "CLOSEDLOOP {label} after {:.1} s: position error {err:.4} m (start 0.36-0.41 m off)",
            CALLS as f32 * DT_S
        ));
    }

    // The law alone (the "control" of the decode + control + allocation + encode),
    // in the same closed loop: allocation, anti-windup and the plant untimed. Only in the
    // `law-alone` image: calling the laws from here too changes how `Controller::step` is
    // inlined (+25-50 instructions on every control step of the default image).
    #[cfg(feature = "law-alone")]
    for (name, mode) in MODES.iter() {
        let gains = Gains::default();
        let r = ref_for(mode);
        let plane = Plane::for_mode(*mode);
        let mut sim = LawLoop {
            plant: Plant::new(vehicle, plane, offset_start(&r.sample(0.0))),
            state: TrackingState::default(),
            reference: RefSample::default(),
            forces: BodyForces::default(),
        };
        let mut buf = [0u8; 40];
        let label = join(&mut buf, "law.", name);
        b.run_state(
            label,
            CALLS,
            &mut sim,
            |s, i| s.reference = r.sample(i as f32 * DT_S),
            |s| s.forces = law_step(&vehicle, &gains, *mode, s),
            |s| {
                let a = allocate(&s.forces, &limits);
                s.state.on_allocation(&s.forces, &a.achieved);
                s.plant.advance(&a.achieved, DT_S);
            },
        );
    }

    // Stress: independent random states near the reference at each call (not a trajectory
    // a vehicle can fly: velocities jump by up to 0.4 m/s from one call to the next), the
    // reference sampled 0.2 s apart. The laws' one-step solvers then start far from their
    // root at every call and take their fallbacks: the worst case.
    for (name, mode) in MODES.iter() {
        let r = ref_for(mode);
        ctl.reset();
        let mut g = Lcg(5);
        let mut buf = [0u8; 40];
        let label = join(&mut buf, "control_step_random.", name);
        b.run(
            label,
            CALLS,
            |i| {
                let rs = r.sample(i as f32 * (100.0 / CALLS as f32));
                (nav_near(&rs, &mut g), rs)
            },
            |(nav, rs)| control_step(&mut ctl, *mode, nav, rs),
        );
    }

    true
}

/// `a` followed by `b` in `buf` (truncated to fit); names are ASCII.
pub fn join<'b>(buf: &'b mut [u8], a: &str, b: &str) -> &'b str {
    let mut n = 0;
    for (dst, src) in buf.iter_mut().zip(a.bytes().chain(b.bytes())) {
        *dst = src;
        n += 1;
    }
    buf.get(..n)
        .and_then(|s| core::str::from_utf8(s).ok())
        .unwrap_or("?")
}

//! The simulator library's own small tests (the CSV writer, the smoother, the served
//! vehicle's bridge and USBL sentences, the identification room): the library has no unit
//! tests of its own (`test = false`), so that `cargo test` does not build it twice.

/// The time series writes every value so that it reads back bit for bit, shortest; the outputs asked for are the ones written.
mod output {
    use host_sim::closed_loop::{RunOutput, Sample};
    use host_sim::output::{row, write_csv_to, write_run_with, Outputs, CSV_COLUMNS, N_COLUMNS};

    fn parse(field: &str) -> f64 {
        field.parse().unwrap()
    }

    #[test]
    fn every_value_reads_back_as_the_same_f64() {
        let awkward = [
            0.1 + 0.2,
            -1.0 / 3.0,
            f64::MIN_POSITIVE / 3.0,
            f64::MAX,
            -0.0,
            1e-300,
            123_456_789.123_456_79,
            f64::from(0.1_f32),
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut log = Vec::new();
        for (i, &a) in awkward.iter().enumerate() {
            let mut s = Sample {
                t_s: i as f64 * 0.01,
                saturated: i % 2 == 0,
                nav_pos_std_m: (i % 3 != 0).then_some([a, -a, 0.5]),
                ..Sample::default()
            };
            s.state.eta = [a, -a, a * 0.5, 1.0, 2.0, a];
            s.state.nu = [a; 6];
            s.pos_err_norm_m = a;
            s.pulse_us = [1500.0, a, 1100.0];
            s.law_errors.yaw_rad = 0.1;
            log.push(s);
        }
        let mut bytes = Vec::new();
        write_csv_to(&mut bytes, &log).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), CSV_COLUMNS.join(","));
        let mut n = 0;
        for (line, s) in lines.zip(&log) {
            let got: Vec<f64> = line.split(',').map(parse).collect();
            let want = row(s);
            assert_eq!(got.len(), N_COLUMNS);
            for (g, w) in got.iter().zip(want) {
                // NaN reads back as NaN; every other value bit for bit (the sign of zero too).
                assert!(
                    g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                    "{g:e} != {w:e} in {line}"
                );
            }
            n += 1;
        }
        assert_eq!(n, log.len());
    }

    #[test]
    fn numbers_are_written_shortest() {
        let s = Sample {
            t_s: 0.25,
            ..Sample::default()
        };
        let mut bytes = Vec::new();
        write_csv_to(&mut bytes, &[s]).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let data = text.lines().nth(1).unwrap();
        assert!(data.starts_with("0.25,0.0,0.0,"), "{data}");
        assert!(data.ends_with(",NaN,NaN,NaN"), "{data}");
        // Every field is short: no padding to a fixed number of digits.
        assert!(data.len() < 6 * N_COLUMNS, "{} bytes: {data}", data.len());
    }

    #[test]
    fn without_the_time_series_and_figures_only_the_summary_is_written() {
        let dir = std::env::temp_dir().join(format!("host-sim-outputs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = RunOutput {
            log: vec![Sample::default(); 3],
            ..RunOutput::default()
        };
        let none = Outputs {
            timeseries: false,
            plots: false,
        };
        assert!(!none.need_log());
        write_run_with(&dir, &out, none).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["summary.json"]);
        let csv_only = Outputs {
            timeseries: true,
            plots: false,
        };
        write_run_with(&dir, &out, csv_only).unwrap();
        let text = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
        assert_eq!(text.lines().count(), 1 + out.log.len());
        assert!(!dir.join("fig_errors.png").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The floor filter's angle wrap.
mod floor {
    use host_sim::closed_loop::floor::wrap;

    #[test]
    fn angles_wrap_into_the_half_open_circle() {
        let pi = std::f64::consts::PI;
        assert!((wrap(3.0 * pi) - pi).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-12);
        assert!((wrap(2.0 * pi + 0.25) - 0.25).abs() < 1e-12);
    }
}

/// An identification run is judged by the room it stays in.
mod ident_room {
    use host_sim::closed_loop::rules::IdentRoom;

    #[test]
    fn an_identification_run_is_judged_by_its_room() {
        let mut room = IdentRoom {
            start_m: [0.0, 5.0, 10.0],
            radius_m: 30.0,
            depth_band_m: 6.0,
            max_horizontal_m: 0.0,
            max_depth_off_m: 0.0,
        };
        room.update(&[20.0, 5.0, 14.0, 0.0, 0.0, 0.0]);
        assert!(room.left().is_none());
        room.update(&[0.0, 5.0, 16.5, 0.0, 0.0, 0.0]);
        let r = room.left().unwrap();
        assert_eq!(r.name, "ident_depth_band");
        assert!(
            (r.figure - 6.5).abs() < 1e-12 && r.threshold == 6.0,
            "{r:?}"
        );
        room.update(&[0.0, 36.0, 10.0, 0.0, 0.0, 0.0]);
        let r = room.left().unwrap();
        assert_eq!(r.name, "ident_room");
        assert!(r.text.contains("identification"), "{}", r.text);
    }
}

/// The Rauch-Tung-Striebel smoother.
mod smoother {
    use host_sim::closed_loop::smoother::{rts, Epoch};
    use nalgebra::{Matrix2, Vector2};

    /// A body moving at constant velocity, its position measured at every epoch: with no
    /// process noise and a diffuse prior the smoothed track is the least-squares line through
    /// the measurements, at every epoch (the forward filter only reaches it at the last).
    #[test]
    fn constant_velocity_smooths_to_the_least_squares_line() {
        let dt = 0.5;
        let r = 0.04;
        let zs = [0.13, 0.41, 1.22, 1.38, 2.05, 2.61, 2.87, 3.66, 3.92, 4.71];
        let phi = Matrix2::new(1.0, dt, 0.0, 1.0);
        let h = nalgebra::RowVector2::new(1.0, 0.0);
        let mut x = Vector2::zeros();
        let mut p = Matrix2::identity() * 1e8;
        let mut epochs = Vec::new();
        for (k, z) in zs.iter().enumerate() {
            let (x_p, p_p, phi_k) = if k == 0 {
                (x, p, Matrix2::identity())
            } else {
                (phi * x, phi * p * phi.transpose(), phi)
            };
            let s = (h * p_p * h.transpose())[0] + r;
            let kg = p_p * h.transpose() / s;
            x = x_p + kg * (z - (h * x_p)[0]);
            p = p_p - kg * s * kg.transpose();
            epochs.push(Epoch {
                t_us: k as u64,
                phi: phi_k,
                x_p,
                p_p,
                x_f: x,
                p_f: p,
            });
        }
        let sm = rts(&epochs, |a, b| a - b).unwrap();
        // Least squares: z = a + b t.
        let n = zs.len() as f64;
        let ts: Vec<f64> = (0..zs.len()).map(|k| k as f64 * dt).collect();
        let (st, sz) = (ts.iter().sum::<f64>(), zs.iter().sum::<f64>());
        let stt: f64 = ts.iter().map(|t| t * t).sum();
        let stz: f64 = ts.iter().zip(&zs).map(|(t, z)| t * z).sum();
        let b = (n * stz - st * sz) / (n * stt - st * st);
        let a = (sz - b * st) / n;
        // Slope variance of the line: r / sum (t - mean)^2.
        let var_b = r / (stt - st * st / n);
        for (k, (xs, ps)) in sm.iter().enumerate() {
            let t = ts[k];
            assert!((xs[0] - (a + b * t)).abs() < 1e-6, "epoch {k}: {}", xs[0]);
            assert!((xs[1] - b).abs() < 1e-6, "epoch {k}: {}", xs[1]);
            // Relative 1e-4: the diffuse prior (1e8) costs digits in the covariance updates.
            assert!((ps[(1, 1)] - var_b).abs() < 1e-4 * var_b, "{}", ps[(1, 1)]);
        }
        // The filter alone is on the line only at the end.
        assert!((epochs[0].x_f[0] - (a + b * ts[0])).abs() > 0.05);
    }

    #[test]
    fn a_broken_prediction_covariance_gives_none() {
        let e = Epoch {
            t_us: 0,
            phi: Matrix2::identity(),
            x_p: Vector2::zeros(),
            p_p: Matrix2::zeros(),
            x_f: Vector2::zeros(),
            p_f: Matrix2::identity(),
        };
        assert!(rts(&[e.clone(), e], |a, b| a - b).is_none());
        assert!(rts::<2>(&[], |a, b| a - b).is_none());
    }
}

/// The served vehicle's USBL sentences read back through the surface's parser.
mod usbl_out {
    use controller_core::nav::PositionFix;
    use host_sim::served::usbl_out::psimssb;
    use sensor_drivers::usbl::{parse, Orientation, Sentence};
    use std::time::{Duration, UNIX_EPOCH};

    #[test]
    fn a_fix_reads_back_through_the_surface_parser() {
        let fix = PositionFix {
            t_us: 12_000_000,
            north_m: 3.25,
            east_m: -1.5,
            std_m: 0.3,
        };
        let at = UNIX_EPOCH + Duration::from_millis(86_400_000 * 3 + 45_296_789);
        let line = psimssb(&fix, 2.5, at);
        let Ok(Sentence::Ssb(s)) = parse(line.trim_end().as_bytes()) else {
            panic!("{line}");
        };
        assert_eq!(s.orientation, Orientation::NorthUp);
        assert!(
            (s.time_of_day_s - 45_296.789).abs() < 1e-6,
            "{}",
            s.time_of_day_s
        );
        assert_eq!((s.x_m, s.y_m, s.depth_m), (-1.5, 3.25, 2.5));
        assert_eq!(s.accuracy_m, Some(0.3));
    }
}

/// The served vehicle's tether bridge: the surface's session numbers and the App's gate.
mod bridge {
    use firmware::protocol::{encode, Command, Decoded, NackReason, Reply, MAX_FRAME_LEN};
    use firmware::protocol::{Board, NavSample};
    use firmware::Config;
    use host_sim::served::bridge::TetherBridge;
    use host_sim::tether::in_process::InProcessFirmware;

    /// The surface's end: its frames and what it decodes.
    struct Surface {
        session: u32,
        seq: u16,
    }

    impl Surface {
        fn frame(&mut self, cmd: &Command) -> (u16, Vec<u8>) {
            let seq = self.seq;
            self.seq += 1;
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode(self.session, seq, cmd, &mut buf).unwrap().to_vec();
            (seq, f)
        }
    }

    fn replies(bytes: &[u8]) -> Vec<(u16, Reply)> {
        let mut dec = firmware::protocol::FrameDecoder::<Reply>::new();
        bytes
            .iter()
            .filter_map(|&b| match dec.push(b) {
                Some(Decoded::Frame { seq, msg, .. }) => Some((seq, msg)),
                _ => None,
            })
            .collect()
    }

    /// The App, the bridge, one exchange: the surface's bytes and the vehicle's inputs in,
    /// what the surface receives out.
    fn exchange(
        app: &mut InProcessFirmware,
        b: &mut TetherBridge,
        surface: &[u8],
        own: &[Command],
    ) -> Vec<(u16, Reply)> {
        // The vehicle's inputs, then (their session open) the held ones, then the surface's.
        let tx = app.pass(&b.own_inputs(own).unwrap());
        let mut r = replies(&b.from_app(&tx).unwrap());
        let tx = app.pass(&b.held().unwrap());
        r.extend(replies(&b.from_app(&tx).unwrap()));
        let tx = app.pass(&b.from_surface(surface).unwrap());
        r.extend(replies(&b.from_app(&tx).unwrap()));
        r
    }

    fn nav(t_us: u64) -> Command {
        Command::Nav(NavSample {
            t_us,
            state: Default::default(),
        })
    }

    #[test]
    fn the_surface_keeps_its_numbers_and_the_apps_gate() {
        let mut app = InProcessFirmware::with_config(Config::fixed_rate(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        // The boot's Hello passes; the vehicle's own session opens before any surface.
        let r = exchange(&mut app, &mut b, &[], &[nav(0)]);
        assert!(matches!(r.first(), Some((_, Reply::Hello { .. }))), "{r:?}");
        let r = exchange(&mut app, &mut b, &[], &[nav(1_000)]);
        assert!(r.is_empty(), "the vehicle's own answers stay inside: {r:?}");
        // The surface opens its session and is answered with its nonce.
        let mut s = Surface { session: 0, seq: 0 };
        let (_, open) = s.frame(&Command::OpenSession { nonce: 77 });
        let r = exchange(&mut app, &mut b, &open, &[nav(2_000)]);
        let Some(&(_, Reply::Session { nonce: 77, session })) = r.first() else {
            panic!("no session: {r:?}");
        };
        s.session = session;
        // Heartbeat and a command, with vehicle inputs between: the surface's numbers back.
        for k in 0..20u64 {
            let (hb, f1) = s.frame(&Command::Heartbeat { t_us: k });
            let (arm, f2) = s.frame(&Command::SetMode(firmware::protocol::Mode::Idle));
            let bytes = [f1, f2].concat();
            let t = 10_000 * (k + 1);
            let r = exchange(&mut app, &mut b, &bytes, &[nav(t), nav(t + 5_000)]);
            assert!(
                r.iter()
                    .any(|(_, m)| matches!(m, Reply::Status(st) if st.heartbeat_seq == hb)),
                "{r:?}"
            );
            assert!(r.contains(&(r[1].0, Reply::Ack { seq: arm })), "{r:?}");
        }
        // A replay is refused by the App, under the surface's number.
        let (old, f) = {
            let seq = s.seq - 1;
            let mut buf = [0u8; MAX_FRAME_LEN];
            let f = encode(s.session, seq, &Command::Disarm, &mut buf)
                .unwrap()
                .to_vec();
            (seq, f)
        };
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert_eq!(
            r.iter().map(|(_, m)| *m).collect::<Vec<_>>(),
            vec![Reply::Nack {
                seq: old,
                reason: NackReason::Replayed
            }]
        );
        // Another session's frame: refused NoSession.
        let mut stranger = Surface {
            session: session ^ 1,
            seq: 500,
        };
        let (n, f) = stranger.frame(&Command::Arm);
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert_eq!(
            r.iter().map(|(_, m)| *m).collect::<Vec<_>>(),
            vec![Reply::Nack {
                seq: n,
                reason: NackReason::NoSession
            }]
        );
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
    }

    #[test]
    fn a_renewed_session_is_not_seen_by_the_surface() {
        let mut app = InProcessFirmware::with_config(Config::fixed_rate(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        let mut s = Surface { session: 0, seq: 0 };
        let (_, open) = s.frame(&Command::OpenSession { nonce: 5 });
        let r = exchange(&mut app, &mut b, &open, &[]);
        let Some(&(_, Reply::Session { session, .. })) =
            r.iter().find(|(_, m)| matches!(m, Reply::Session { .. }))
        else {
            panic!("no session: {r:?}");
        };
        s.session = session;
        // The pilot's sticks seen at centre: the stick gate open.
        let (_, f) = s.frame(&Command::ManualThrust(Default::default()));
        exchange(&mut app, &mut b, &f, &[]);
        assert!(app.app().autopilot().sticks_seen_centred());
        // Far more vehicle inputs than one session's numbers.
        for k in 0..70_000u64 {
            exchange(&mut app, &mut b, &[], &[nav(k * 10)]);
        }
        let (hb, f) = s.frame(&Command::Heartbeat { t_us: 1 });
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert!(
            r.iter()
                .any(|(_, m)| matches!(m, Reply::Status(st) if st.heartbeat_seq == hb)),
            "{r:?}"
        );
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
        // The bridge's renewals are the same surface to the App: the gate stays open.
        assert!(app.app().autopilot().sticks_seen_centred());
        // The surface renews its own session (framed in it): the same surface still.
        let (_, f) = s.frame(&Command::OpenSession { nonce: 6 });
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert!(r
            .iter()
            .any(|(_, m)| matches!(m, Reply::Session { nonce: 6, .. })));
        assert!(app.app().autopilot().sticks_seen_centred());
        // Another surface (its `OpenSession` in no session): the gate closes.
        let mut other = Surface { session: 0, seq: 0 };
        let (_, f) = other.frame(&Command::OpenSession { nonce: 7 });
        let r = exchange(&mut app, &mut b, &f, &[]);
        assert!(r
            .iter()
            .any(|(_, m)| matches!(m, Reply::Session { nonce: 7, .. })));
        assert!(!app.app().autopilot().sticks_seen_centred());
    }

    /// A new surface (a new session) after the first: its numbers start again, the
    /// vehicle's inputs never stopped; its commands are answered under its numbers.
    #[test]
    fn a_second_surface_after_the_first() {
        let mut app = InProcessFirmware::with_config(Config::fixed_rate(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        let mut t = 0;
        let mut next_nav = || {
            t += 20_000;
            nav(t)
        };
        for nonce in [1, 2] {
            let mut s = Surface { session: 0, seq: 0 };
            let (_, open) = s.frame(&Command::OpenSession { nonce });
            let r = exchange(&mut app, &mut b, &open, &[next_nav()]);
            let Some(&(_, Reply::Session { session, .. })) =
                r.iter().find(|(_, m)| matches!(m, Reply::Session { .. }))
            else {
                panic!("no session: {r:?}");
            };
            s.session = session;
            for _ in 0..50 {
                let (k, f) = s.frame(&Command::SetMode(firmware::protocol::Mode::Idle));
                let r = exchange(&mut app, &mut b, &f, &[next_nav(), next_nav()]);
                let answers: Vec<Reply> = r.iter().map(|(_, m)| *m).collect();
                assert_eq!(answers, vec![Reply::Ack { seq: k }], "surface {nonce}");
            }
        }
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
    }

    /// Before a lock-step App: the surface's heartbeat is stamped with the vehicle's time
    /// (its `Status` says that time, not the surface's), the step's telemetry reaches the
    /// surface every 100 ms, and a step framed after the surface's `OpenSession` has been
    /// answered goes in the new session.
    #[test]
    fn a_lock_step_app_behind_the_bridge() {
        let mut app = InProcessFirmware::with_config(Config::lockstep(Board::Host)).unwrap();
        let mut b = TetherBridge::new();
        b.set_telemetry_period(100_000);
        let mut s = Surface { session: 0, seq: 0 };
        let (_, open) = s.frame(&Command::OpenSession { nonce: 9 });
        let r = exchange(&mut app, &mut b, &open, &[]);
        assert!(b.surface_opening().is_none(), "{r:?}");
        let Some(&(_, Reply::Session { session, .. })) =
            r.iter().find(|(_, m)| matches!(m, Reply::Session { .. }))
        else {
            panic!("no session: {r:?}");
        };
        s.session = session;
        let mut telemetry = 0;
        for k in 0..50u64 {
            let t_us = k * 20_000;
            b.set_vehicle_time(t_us);
            // The surface's clock is far ahead of the vehicle's.
            let (hb, f) = s.frame(&Command::Heartbeat {
                t_us: 3_600_000_000,
            });
            let rx = b.from_surface(&f).unwrap();
            let tx = app.pass(&rx);
            let mut r = replies(&b.from_app(&tx).unwrap());
            let (_, step) = b.own_frame(&nav(t_us)).unwrap().unwrap();
            let tx = app.pass(&step);
            r.extend(replies(&b.from_app(&tx).unwrap()));
            assert!(
                r.iter().any(|(_, m)| matches!(
                    m,
                    Reply::Status(st) if st.heartbeat_seq == hb && st.t_us == t_us
                )),
                "{r:?}"
            );
            telemetry += r
                .iter()
                .filter(|(_, m)| matches!(m, Reply::Telemetry(_)))
                .count();
        }
        // 50 steps of 20 ms: one telemetry frame per 100 ms.
        assert_eq!(telemetry, 10);
        assert_eq!((b.own_refused, b.own_refused_why), (0, None));
    }
}

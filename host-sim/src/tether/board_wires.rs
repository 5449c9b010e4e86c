//! The emulated board's wires besides the tether: its DVL UART (USART2, QEMU `-serial` 1),
//! on which the simulated DVL's A50 reports go as the DVL sends them ([`DvlWire`]), and its
//! health inputs (USART3, `-serial` 2): the simulated battery, leak probe and enclosure
//! sensor ([`VehicleElectrics`]) read as the power-sense module's ADC pins and the probe's
//! GPIO would be, sent as a harness frame of [`HealthSample`] before each step
//! (`firmware::health::HarnessHealth` takes it). The in-process firmware reads the same
//! [`DvlWire`] and [`VehicleElectrics`] in memory (`in_process`).

use anyhow::{anyhow, Context, Result};
use controller_core::alloc::PwmMap;
use firmware::harness::seal;
use firmware::protocol::{HealthParams, HealthSample, MAX_FRAME_LEN};
use sim_scenario::setup::RunSetup;
use sim_world::battery::VehicleElectrics;
use sim_world::sensors::DvlWire;
use std::io::Write;
use std::net::TcpStream;

/// The DVL's and the health inputs' sockets of an emulated board, and what feeds them.
pub struct BoardWires {
    dvl: DvlWire,
    dvl_out: TcpStream,
    health_out: TcpStream,
    electrics: VehicleElectrics,
    params: HealthParams,
    seq: u16,
    /// Health frames sent.
    pub health_frames: u64,
    /// DVL bytes sent.
    pub dvl_bytes: u64,
}

impl BoardWires {
    /// The scenario's battery and health events (`[battery]`, `[health]`) on `health_out`,
    /// the DVL on `dvl_out`.
    pub fn new(sc: &RunSetup, dvl_out: TcpStream, health_out: TcpStream) -> Result<Self> {
        let params = sc.health.params(&sc.battery)?;
        let electrics = VehicleElectrics::new(
            sc.battery,
            sc.health.events()?,
            params,
            PwmMap::for_vehicle(sc.vehicle()),
            f64::from(sc.vehicle_params.thrust_max_forward_n),
        );
        dvl_out.set_nodelay(true)?;
        health_out.set_nodelay(true)?;
        Ok(Self {
            dvl: DvlWire::default(),
            dvl_out,
            health_out,
            electrics,
            params,
            seq: 0,
            health_frames: 0,
            dvl_bytes: 0,
        })
    }

    /// The DVL's line (a clone: the reports written on it go out at the next [`Self::send`]).
    pub fn dvl_wire(&self) -> DvlWire {
        self.dvl.clone()
    }

    /// The scenario's health parameters, which the vehicle is given at the start.
    pub fn health_params(&self) -> HealthParams {
        self.params
    }

    /// The simulated battery and events (the truth the vehicle measures).
    pub fn electrics(&self) -> &VehicleElectrics {
        &self.electrics
    }

    /// Before a step: the DVL's waiting bytes and the health inputs now.
    pub fn send(&mut self) -> Result<()> {
        let mut bytes = vec![0u8; self.dvl.pending()];
        let n = embedded_io::Read::read(&mut self.dvl, &mut bytes).unwrap_or(0);
        if n > 0 {
            self.dvl_out
                .write_all(&bytes[..n])
                .context("writing the DVL's UART")?;
            self.dvl_bytes += n as u64;
        }
        let sample: HealthSample = self.electrics.wire().sample();
        let mut out = [0u8; MAX_FRAME_LEN];
        let frame =
            seal(self.seq, &sample, &mut out).map_err(|e| anyhow!("health frame: {e:?}"))?;
        self.health_out
            .write_all(frame)
            .context("writing the health inputs' UART")?;
        self.seq = self.seq.wrapping_add(1);
        self.health_frames += 1;
        Ok(())
    }

    /// After a step at `t_us`: the battery advanced with the pulses the board set.
    pub fn advance(&mut self, t_us: u64, pulses_us: [u16; 3]) {
        self.electrics.advance(t_us, pulses_us.map(f32::from));
    }
}

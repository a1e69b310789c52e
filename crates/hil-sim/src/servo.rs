//! A hobby servo turning a tendon winch: follows its PWM command with a load-dependent slew
//! rate and stalls above its torque; without pulses it goes limp and the tendon back-drives it.

/// Servo and winch data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSpec {
    /// No-load speed, °/s (a 60 kg·cm-class digital servo: 0.15 s/60° at 7.4 V → 400 °/s).
    pub no_load_deg_per_s: f64,
    /// Stall torque, N·m (60 kg·cm ≈ 5.9 N·m).
    pub stall_torque_n_m: f64,
    /// Pulse width at 0°, µs.
    pub min_pulse_us: f64,
    /// Pulse width at `range_deg`, µs.
    pub max_pulse_us: f64,
    /// Mechanical range, degrees.
    pub range_deg: f64,
    /// Torque that back-drives the unpowered gear train, N·m (≈ 5 N of tendon on the 60 mm
    /// spool: a metal-gear 60 kg·cm servo turns by hand with some effort).
    pub backdrive_torque_n_m: f64,
    /// Back-driven speed per N·m above that, °/s (the motor shorted through its idle driver
    /// acts as a brake).
    pub backdrive_deg_per_s_per_n_m: f64,
}

impl Default for ServoSpec {
    fn default() -> Self {
        Self {
            no_load_deg_per_s: 400.0,
            stall_torque_n_m: 5.9,
            min_pulse_us: 500.0,
            max_pulse_us: 2500.0,
            range_deg: 180.0,
            backdrive_torque_n_m: 0.3,
            backdrive_deg_per_s_per_n_m: 100.0,
        }
    }
}

/// One servo's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Servo {
    /// Its data.
    pub spec: ServoSpec,
    /// Shaft angle now, degrees.
    pub angle_deg: f64,
    /// Angle the last valid pulse asked for, degrees.
    pub command_deg: f64,
    /// Jammed: it does not move at all (a stripped gear train). No injectable fault sets it;
    /// `servo-stall` weakens the supply instead (see [`crate::Fault::ServoStall`]).
    pub jammed: bool,
    /// It could not move toward its command in the last step (load above stall torque).
    pub stalled: bool,
    /// No pulses (duty 0): unpowered, it drives nothing and the load may back-drive it.
    pub limp: bool,
}

impl Servo {
    /// A servo resting at `angle_deg`.
    pub fn new(spec: ServoSpec, angle_deg: f64) -> Self {
        Self {
            spec,
            angle_deg,
            command_deg: angle_deg,
            jammed: false,
            stalled: false,
            limp: false,
        }
    }

    /// Takes a pulse width (µs): no pulse at all (0) turns the servo off (limp, until the next
    /// valid pulse); a pulse outside the servo's range is ignored and the servo holds its last
    /// command, as digital servos do.
    pub fn set_pulse_us(&mut self, pulse_us: f64) {
        let s = &self.spec;
        if pulse_us <= 0.0 {
            self.limp = true;
            self.command_deg = self.angle_deg;
            return;
        }
        if pulse_us >= s.min_pulse_us - 50.0 && pulse_us <= s.max_pulse_us + 50.0 {
            self.limp = false;
            let frac =
                ((pulse_us - s.min_pulse_us) / (s.max_pulse_us - s.min_pulse_us)).clamp(0.0, 1.0);
            self.command_deg = frac * s.range_deg;
        }
    }

    /// Moves toward the command for `dt_s` against `load_torque_n_m`, the torque the tendon
    /// puts on the shaft (positive: opposing an increase of the angle). Speed falls linearly with the
    /// opposing torque (the DC motor's torque–speed line) and is zero at the stall torque;
    /// moving with the load is at full speed.
    /// A limp servo turns with the load (toward slack for a tendon) when it exceeds the
    /// back-drive torque.
    #[inline]
    pub fn step(&mut self, dt_s: f64, load_torque_n_m: f64) {
        self.stalled = false;
        if self.limp {
            let excess = load_torque_n_m.abs() - self.spec.backdrive_torque_n_m;
            if excess > 0.0 && !self.jammed {
                let d = excess * self.spec.backdrive_deg_per_s_per_n_m * dt_s;
                // A positive load opposes an increasing angle: it turns the shaft down.
                let next = self.angle_deg - d * load_torque_n_m.signum();
                self.angle_deg = next.clamp(0.0, self.spec.range_deg);
            }
            self.command_deg = self.angle_deg;
            return;
        }
        let err = self.command_deg - self.angle_deg;
        if self.jammed || err == 0.0 {
            self.stalled = self.jammed && err.abs() > 0.5;
            return;
        }
        let opposing = if err > 0.0 {
            load_torque_n_m.max(0.0)
        } else {
            (-load_torque_n_m).max(0.0)
        };
        let frac = 1.0 - opposing / self.spec.stall_torque_n_m;
        if frac <= 0.0 {
            self.stalled = true;
            return;
        }
        let max_step = self.spec.no_load_deg_per_s * frac * dt_s;
        self.angle_deg += err.clamp(-max_step, max_step);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_the_pulse_at_its_no_load_speed() {
        let mut s = Servo::new(ServoSpec::default(), 0.0);
        s.set_pulse_us(1500.0);
        assert_eq!(s.command_deg, 90.0);
        for _ in 0..100 {
            s.step(1e-3, 0.0);
        }
        assert!((s.angle_deg - 40.0).abs() < 1e-9, "{}", s.angle_deg);
        for _ in 0..200 {
            s.step(1e-3, 0.0);
        }
        assert_eq!(s.angle_deg, 90.0);
    }

    #[test]
    fn slows_under_load_and_stalls_above_its_torque() {
        let mut s = Servo::new(ServoSpec::default(), 0.0);
        s.set_pulse_us(2500.0);
        s.step(0.1, 0.5 * s.spec.stall_torque_n_m);
        assert!((s.angle_deg - 20.0).abs() < 1e-9);
        let before = s.angle_deg;
        s.step(0.1, 1.1 * s.spec.stall_torque_n_m);
        assert_eq!(s.angle_deg, before);
        assert!(s.stalled);
        // Letting out with the load is not slowed; a load the other way opposes it.
        let mut r = s;
        r.set_pulse_us(500.0);
        r.step(0.01, -1.1 * r.spec.stall_torque_n_m);
        assert_eq!(r.angle_deg, before);
        s.set_pulse_us(500.0);
        s.step(0.01, 10.0);
        assert!((s.angle_deg - (before - 4.0)).abs() < 1e-9);
    }

    #[test]
    fn without_pulses_it_goes_limp_and_the_load_back_drives_it() {
        let mut s = Servo::new(ServoSpec::default(), 90.0);
        s.set_pulse_us(0.0);
        assert!(s.limp);
        // Below the back-drive torque it stays.
        s.step(1.0, 0.2);
        assert_eq!(s.angle_deg, 90.0);
        // 1.3 N·m (≈ 22 N of tendon): 1 N·m above it, 100 °/s toward slack.
        s.step(0.1, 1.3);
        assert!((s.angle_deg - 80.0).abs() < 1e-9, "{}", s.angle_deg);
        assert!(!s.stalled && s.command_deg == s.angle_deg);
        // A valid pulse powers it again.
        s.set_pulse_us(1500.0);
        assert!(!s.limp && s.command_deg == 90.0);
    }

    #[test]
    fn ignores_pulses_out_of_range_and_jams_when_faulted() {
        let mut s = Servo::new(ServoSpec::default(), 10.0);
        s.set_pulse_us(5_000.0);
        assert_eq!(s.command_deg, 10.0);
        assert!(!s.limp);
        s.jammed = true;
        s.set_pulse_us(2500.0);
        s.step(1.0, 0.0);
        assert_eq!(s.angle_deg, 10.0);
        assert!(s.stalled);
    }
}

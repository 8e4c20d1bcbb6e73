//! Slideway lubrication: at power-up and after every configured travel of an axis; the
//! pressure switch must confirm within the timeout.

use super::fault::Fault;

/// Lube pump timing.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LubeParams {
    pub interval_mm: f64,
    pub pressure_timeout_s: f64,
    pub pump_run_s: f64,
}

/// The lubrication cycle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lube {
    params: LubeParams,
    running: bool,
    elapsed_s: f64,
    confirmed: bool,
    /// Travel of X and Y since the last lubrication.
    travel_mm: [f64; 2],
    cycles_done: u32,
}

impl Lube {
    /// Starts with the power-up lubrication due.
    pub fn new(p: LubeParams) -> Self {
        Self {
            params: p,
            running: true,
            elapsed_s: 0.0,
            confirmed: false,
            travel_mm: [0.0; 2],
            cycles_done: 0,
        }
    }

    pub fn pump_on(&self) -> bool {
        self.running
    }

    /// Lubrication cycles completed since power-up.
    pub fn cycles_done(&self) -> u32 {
        self.cycles_done
    }

    /// Travel since the last lubrication, the larger of X and Y.
    pub fn travel_mm(&self) -> f64 {
        self.travel_mm[0].max(self.travel_mm[1])
    }

    /// One cycle: `dx_mm`, `dy_mm` travelled; `pressure_ok` from the switch.
    pub fn step(&mut self, dt_s: f64, dx_mm: f64, dy_mm: f64, pressure_ok: bool) -> Result<(), Fault> {
        self.travel_mm[0] += dx_mm.abs();
        self.travel_mm[1] += dy_mm.abs();
        if !self.running && self.travel_mm() >= self.params.interval_mm {
            self.running = true;
            self.elapsed_s = 0.0;
            self.confirmed = false;
        }
        if !self.running {
            return Ok(());
        }
        self.elapsed_s += dt_s;
        self.confirmed |= pressure_ok;
        if !self.confirmed && self.elapsed_s > self.params.pressure_timeout_s {
            self.running = false;
            return Err(Fault::LubeTimeout);
        }
        if self.confirmed && self.elapsed_s >= self.params.pump_run_s {
            self.running = false;
            self.travel_mm = [0.0; 2];
            self.cycles_done += 1;
        }
        Ok(())
    }

    /// Asks for a new lubrication (after a lube fault is reset).
    pub fn request(&mut self) {
        if !self.running {
            self.running = true;
            self.elapsed_s = 0.0;
            self.confirmed = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: LubeParams = LubeParams {
        interval_mm: 5000.0,
        pressure_timeout_s: 10.0,
        pump_run_s: 5.0,
    };

    #[test]
    fn power_up_lubrication_then_every_5_m() {
        let mut l = Lube::new(P);
        assert!(l.pump_on());
        for _ in 0..5000 {
            l.step(0.001, 0.0, 0.0, true).unwrap();
        }
        assert!(!l.pump_on());
        assert_eq!(l.cycles_done(), 1);
        for _ in 0..4999 {
            l.step(0.001, 0.0, 1.0, false).unwrap();
        }
        assert!(!l.pump_on());
        l.step(0.001, 0.0, 1.0, false).unwrap();
        assert!(l.pump_on(), "5 m of Y travel");
    }

    #[test]
    fn no_pressure_within_the_timeout_is_a_fault() {
        let mut l = Lube::new(P);
        let mut result = Ok(());
        for _ in 0..10_001 {
            result = l.step(0.001, 0.0, 0.0, false);
            if result.is_err() {
                break;
            }
        }
        assert_eq!(result, Err(Fault::LubeTimeout));
        assert!(!l.pump_on());
    }
}

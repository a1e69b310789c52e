//! A multistable axial element: a piecewise-linear force–extension law with several stable
//! wells, joined by snap-through branches of negative stiffness.
//!
//! Between two neighbouring wells `j` and `j+1` the curve rises from well `j` with the well's
//! stiffness to the tension barrier `+U` (the snap-out threshold toward the longer state), falls
//! along a negative-stiffness branch to the compression barrier `−C` (the snap-back threshold),
//! and rises again into well `j+1`. Under a fixed force the element therefore has no
//! equilibrium in well `j` once the force exceeds `U`, and none in well `j+1` once it falls
//! below `−C`: that is a snap-through, and the gap between `U` and `−C` is the hysteresis.
//! Outside the first and last wells the curve continues with the wells' stiffness, and past
//! `contact_mm` below the first well panels touch and a much stiffer contact law takes over.
//!
//! Forces are in newtons, tension positive; heights in millimetres.

/// A stable state: its height and the stiffness around it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Well {
    /// Rest height of the element in this state.
    pub height_mm: f64,
    /// Axial stiffness around the well.
    pub stiffness_n_per_mm: f64,
}

/// The barriers between two neighbouring wells.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Barrier {
    /// Tension that snaps the element from the shorter well to the longer one.
    pub tension_n: f64,
    /// Compression (a positive number) that snaps it from the longer well back to the shorter.
    pub compression_n: f64,
}

/// The force–extension law of one module.
#[derive(Debug, Clone, PartialEq)]
pub struct MultistableCurve {
    wells: Vec<Well>,
    barriers: Vec<Barrier>,
    contact_mm: f64,
    contact_stiffness_n_per_mm: f64,
    /// What the laws below derive from each barrier, computed once: the curve is evaluated
    /// several times in every 1 ms physics step, and these are the same divisions each time.
    spans: Vec<Span>,
    /// Force of the first well's law at the contact height.
    at_contact_n: f64,
}

/// The derived heights and slope of one barrier ([`MultistableCurve::barrier_span`]), with the
/// shorter well's law beside them (what the force law reads in one place).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Span {
    /// The shorter well.
    lo: Well,
    /// The tension barrier, N.
    tension_n: f64,
    /// Height of the tension peak.
    peak_mm: f64,
    /// Height of the compression valley.
    valley_mm: f64,
    /// Slope of the snap-through branch (negative).
    slope_n_per_mm: f64,
    /// Where the snap-through branch crosses zero force (the basin boundary).
    zero_mm: f64,
}

/// Why a curve's parameters were rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurveError {
    /// Needs at least one well and exactly one barrier fewer than wells.
    #[error(
        "a curve needs n >= 1 wells and n - 1 barriers (got {wells} wells, {barriers} barriers)"
    )]
    Shape {
        /// Wells given.
        wells: usize,
        /// Barriers given.
        barriers: usize,
    },
    /// A value is not finite and positive, or the wells are not in increasing height order.
    #[error("well heights must increase and every stiffness and barrier must be positive")]
    NotPositive,
    /// The tension peak of a barrier lies above its compression valley: the wells are too close
    /// for the given stiffness and barrier forces.
    #[error("barrier {index}: the tension peak at {peak_mm:.2} mm is not below the compression valley at {valley_mm:.2} mm")]
    Overlap {
        /// Barrier index.
        index: usize,
        /// Height of the tension peak.
        peak_mm: f64,
        /// Height of the compression valley.
        valley_mm: f64,
    },
}

impl MultistableCurve {
    /// A curve from its wells (increasing height), the barriers between them, the height
    /// below which panels touch, and the stiffness of that contact.
    pub fn new(
        wells: Vec<Well>,
        barriers: Vec<Barrier>,
        contact_mm: f64,
        contact_stiffness_n_per_mm: f64,
    ) -> Result<Self, CurveError> {
        if wells.is_empty() || barriers.len() + 1 != wells.len() {
            return Err(CurveError::Shape {
                wells: wells.len(),
                barriers: barriers.len(),
            });
        }
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let ok = wells
            .iter()
            .all(|w| pos(w.stiffness_n_per_mm) && w.height_mm.is_finite())
            && wells.windows(2).all(|w| w[0].height_mm < w[1].height_mm)
            && barriers
                .iter()
                .all(|b| pos(b.tension_n) && pos(b.compression_n))
            && pos(contact_stiffness_n_per_mm)
            && contact_mm.is_finite()
            && contact_mm < wells[0].height_mm;
        if !ok {
            return Err(CurveError::NotPositive);
        }
        let mut spans = Vec::with_capacity(barriers.len());
        for i in 0..barriers.len() {
            let (lo, hi, b) = (wells[i], wells[i + 1], barriers[i]);
            let peak_mm = lo.height_mm + b.tension_n / lo.stiffness_n_per_mm;
            let valley_mm = hi.height_mm - b.compression_n / hi.stiffness_n_per_mm;
            if peak_mm >= valley_mm {
                return Err(CurveError::Overlap {
                    index: i,
                    peak_mm,
                    valley_mm,
                });
            }
            spans.push(Span {
                lo,
                tension_n: b.tension_n,
                peak_mm,
                valley_mm,
                slope_n_per_mm: -(b.tension_n + b.compression_n) / (valley_mm - peak_mm),
                zero_mm: peak_mm
                    + (valley_mm - peak_mm) * b.tension_n / (b.tension_n + b.compression_n),
            });
        }
        let first = wells[0];
        Ok(Self {
            at_contact_n: first.stiffness_n_per_mm * (contact_mm - first.height_mm),
            wells,
            barriers,
            contact_mm,
            contact_stiffness_n_per_mm,
            spans,
        })
    }

    /// The wells, shortest first.
    pub fn wells(&self) -> &[Well] {
        &self.wells
    }

    /// The barriers between neighbouring wells.
    pub fn barriers(&self) -> &[Barrier] {
        &self.barriers
    }

    /// The height below which panels touch, and the stiffness of that contact.
    pub fn contact(&self) -> (f64, f64) {
        (self.contact_mm, self.contact_stiffness_n_per_mm)
    }

    /// Heights of the tension peak and the compression valley of barrier `i`.
    pub fn barrier_span(&self, i: usize) -> (f64, f64) {
        let s = self.spans[i];
        (s.peak_mm, s.valley_mm)
    }

    /// Internal force of the element at height `h_mm` (tension positive: the force with which
    /// it pulls its ends together).
    pub fn force_n(&self, h_mm: f64) -> f64 {
        self.force_and_stiffness(h_mm).0
    }

    /// Force and its slope dF/dh (negative on a snap-through branch).
    pub fn force_and_stiffness(&self, h_mm: f64) -> (f64, f64) {
        if h_mm < self.contact_mm {
            return (
                self.at_contact_n + self.contact_stiffness_n_per_mm * (h_mm - self.contact_mm),
                self.contact_stiffness_n_per_mm,
            );
        }
        // Past barrier i's valley, h is on well i + 1's branch up to the next peak: the next
        // span's (or, after the last, the last well's) law.
        for s in &self.spans {
            if h_mm <= s.peak_mm {
                let lo = s.lo;
                return (
                    lo.stiffness_n_per_mm * (h_mm - lo.height_mm),
                    lo.stiffness_n_per_mm,
                );
            }
            if h_mm < s.valley_mm {
                let slope = s.slope_n_per_mm;
                return (s.tension_n + slope * (h_mm - s.peak_mm), slope);
            }
        }
        let last = self.wells[self.wells.len() - 1];
        (
            last.stiffness_n_per_mm * (h_mm - last.height_mm),
            last.stiffness_n_per_mm,
        )
    }

    /// The well whose basin holds `h_mm` when unloaded: the element relaxes to it at zero force.
    /// The basin boundary of barrier `i` is where its snap-through branch crosses zero force.
    pub fn basin(&self, h_mm: f64) -> usize {
        self.spans
            .iter()
            .position(|s| h_mm < s.zero_mm)
            .unwrap_or(self.wells.len() - 1)
    }

    /// The well whose stable branch holds `h_mm`, or `None` on a snap-through branch.
    pub fn stable_well(&self, h_mm: f64) -> Option<usize> {
        for (i, s) in self.spans.iter().enumerate() {
            if h_mm <= s.peak_mm {
                return Some(i);
            }
            if h_mm < s.valley_mm {
                return None;
            }
        }
        Some(self.wells.len() - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bistable() -> MultistableCurve {
        MultistableCurve::new(
            vec![
                Well {
                    height_mm: 10.0,
                    stiffness_n_per_mm: 2.0,
                },
                Well {
                    height_mm: 50.0,
                    stiffness_n_per_mm: 10.0,
                },
            ],
            vec![Barrier {
                tension_n: 20.0,
                compression_n: 50.0,
            }],
            2.0,
            100.0,
        )
        .unwrap()
    }

    #[test]
    fn wells_are_force_free_and_barriers_sit_where_stiffness_puts_them() {
        let c = bistable();
        assert_eq!(c.force_n(10.0), 0.0);
        assert_eq!(c.force_n(50.0), 0.0);
        let (peak, valley) = c.barrier_span(0);
        assert!((peak - 20.0).abs() < 1e-12);
        assert!((valley - 45.0).abs() < 1e-12);
        assert!((c.force_n(peak) - 20.0).abs() < 1e-9);
        assert!((c.force_n(valley) + 50.0).abs() < 1e-9);
    }

    #[test]
    fn snap_branch_has_negative_stiffness_and_force_is_continuous() {
        let c = bistable();
        let (k, s) = c.force_and_stiffness(30.0);
        assert!(s < 0.0, "{s}");
        assert!(k.abs() < 20.0);
        let mut prev = c.force_n(0.0);
        let mut h = 0.0;
        while h < 70.0 {
            h += 0.01;
            let f = c.force_n(h);
            assert!((f - prev).abs() <= 1.0 + 1e-9, "jump at {h}: {prev} -> {f}");
            prev = f;
        }
    }

    #[test]
    fn basins_split_at_the_zero_force_crossing() {
        let c = bistable();
        // zero crossing: 20 + 25 * 20/70 = 27.142857
        assert_eq!(c.basin(27.0), 0);
        assert_eq!(c.basin(27.3), 1);
        assert_eq!(c.stable_well(19.0), Some(0));
        assert_eq!(c.stable_well(30.0), None);
        assert_eq!(c.stable_well(46.0), Some(1));
    }

    #[test]
    fn contact_is_stiff() {
        let c = bistable();
        let (_, k) = c.force_and_stiffness(1.0);
        assert_eq!(k, 100.0);
        assert!((c.force_n(1.0) - (-16.0 - 100.0)).abs() < 1e-9);
    }

    #[test]
    fn overlapping_barriers_are_rejected() {
        let err = MultistableCurve::new(
            vec![
                Well {
                    height_mm: 10.0,
                    stiffness_n_per_mm: 1.0,
                },
                Well {
                    height_mm: 20.0,
                    stiffness_n_per_mm: 1.0,
                },
            ],
            vec![Barrier {
                tension_n: 8.0,
                compression_n: 8.0,
            }],
            1.0,
            50.0,
        )
        .unwrap_err();
        assert!(matches!(err, CurveError::Overlap { index: 0, .. }), "{err}");
    }
}

//! Where the sun is: NREL's Solar Position Algorithm (Reda & Andreas 2003, ±0.0003°) through
//! the `solar-positioning` crate, with the site, ΔT and the atmosphere explicit.
//!
//! * Azimuth is in degrees clockwise from north (SPA's Φ, "eastward from north"); zenith is
//!   the topocentric zenith angle, corrected for refraction with [`Atmosphere`] when the sun's
//!   centre is above SPA's sunrise elevation −0.83337°; elevation = 90° − zenith.
//! * The sun is **up** when its unrefracted centre is above −0.83337° (the upper limb on the
//!   horizon after standard refraction, SPA's and pvlib's sunrise definition), so "up" and the
//!   reported sunrise/sunset agree.
//! * ΔT (TT − UT1, seconds) is explicit; [`default_delta_t`] is the crate's Espenak–Meeus
//!   estimate for the month (updated fits from 2015), documented in `docs/sun.md`.
//!
//! Times are parsed here too (RFC 3339 instants, `±HH:MM` offsets, `HH:MM` clock times and
//! durations such as `10m`), so that the command line and the tests refuse the same inputs.

use chrono::{DateTime, Duration, FixedOffset, NaiveDate, NaiveTime, TimeZone, Utc};
use solar_positioning::time::JulianDate;
use solar_positioning::{Horizon, Location, RefractionCorrection, SolarEvents, SolarPositions};

/// SPA's sunrise/sunset elevation of the sun's centre (refraction 0.5667° + radius 0.26667°).
pub const SUNRISE_ELEVATION_DEG: f64 = -0.83337;

/// What was wrong with a sun query.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SunError {
    /// Latitude outside [−90°, 90°] or not finite.
    #[error("latitude {0}° is outside [-90°, 90°]")]
    Latitude(f64),
    /// Longitude outside [−180°, 180°] or not finite.
    #[error("longitude {0}° is outside [-180°, 180°]")]
    Longitude(f64),
    /// Elevation above sea level not finite or outside [−500 m, 10 000 m].
    #[error("elevation {0} m is outside [-500, 10000] m")]
    Elevation(f64),
    /// ΔT not finite or outside ±10 000 s.
    #[error("ΔT {0} s is outside [-10000, 10000] s")]
    DeltaT(f64),
    /// Pressure not in (0, 2000] hPa or temperature not in [−90, 60] °C.
    #[error("atmosphere {0} hPa, {1} °C is outside (0, 2000] hPa × [-90, 60] °C")]
    Atmosphere(f64, f64),
    /// A time that does not parse or does not exist.
    #[error("{0}")]
    Time(String),
    /// Outside SPA's valid years (−2000 … 6000) or another SPA refusal.
    #[error("SPA: {0}")]
    Spa(String),
}

/// An observer on the Earth, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    lat_deg: f64,
    lon_deg: f64,
    elevation_m: f64,
}

impl Site {
    /// A site from latitude (° north, [−90, 90]), longitude (° east, [−180, 180]) and
    /// elevation above sea level (m, [−500, 10 000]).
    pub fn new(lat_deg: f64, lon_deg: f64, elevation_m: f64) -> Result<Site, SunError> {
        if !(lat_deg.is_finite() && (-90.0..=90.0).contains(&lat_deg)) {
            return Err(SunError::Latitude(lat_deg));
        }
        if !(lon_deg.is_finite() && (-180.0..=180.0).contains(&lon_deg)) {
            return Err(SunError::Longitude(lon_deg));
        }
        if !(elevation_m.is_finite() && (-500.0..=10_000.0).contains(&elevation_m)) {
            return Err(SunError::Elevation(elevation_m));
        }
        Ok(Site {
            lat_deg,
            lon_deg,
            elevation_m,
        })
    }

    /// Latitude, ° north.
    pub fn lat_deg(&self) -> f64 {
        self.lat_deg
    }

    /// Longitude, ° east.
    pub fn lon_deg(&self) -> f64 {
        self.lon_deg
    }

    /// Elevation above sea level, m.
    pub fn elevation_m(&self) -> f64 {
        self.elevation_m
    }

    fn location(&self) -> Location {
        Location {
            latitude: self.lat_deg,
            longitude: self.lon_deg,
        }
    }
}

/// The air the refraction correction assumes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Atmosphere {
    /// Pressure, hPa (mbar).
    pub pressure_hpa: f64,
    /// Temperature, °C.
    pub temperature_c: f64,
}

impl Default for Atmosphere {
    /// pvlib's `spa_python` defaults: 101 325 Pa and 12 °C (annual means for a generic site).
    fn default() -> Self {
        Atmosphere {
            pressure_hpa: 1013.25,
            temperature_c: 12.0,
        }
    }
}

/// The air temperatures a site can have, °C: Earth's surface records are −89.2 °C (Vostok,
/// 1983) and 56.7 °C (Death Valley, 1913). SPA's refraction term scales with 283 / (273 + T):
/// solar-positioning accepts (−273, 100] °C, but toward −273 °C the term diverges (at
/// −272.999 °C it lifts a sun 18° from the zenith past it, and SPA fails), so the range is the
/// physical one.
pub const TEMPERATURE_RANGE_C: (f64, f64) = (-90.0, 60.0);

impl Atmosphere {
    fn correction(&self) -> Result<RefractionCorrection, SunError> {
        let (lo, hi) = TEMPERATURE_RANGE_C;
        if !(lo..=hi).contains(&self.temperature_c) {
            return Err(SunError::Atmosphere(self.pressure_hpa, self.temperature_c));
        }
        RefractionCorrection::new(self.pressure_hpa, self.temperature_c)
            .map_err(|_| SunError::Atmosphere(self.pressure_hpa, self.temperature_c))
    }
}

/// ΔT = TT − UT1 in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaT(f64);

impl DeltaT {
    /// An explicit ΔT, seconds ([−10 000, 10 000]).
    pub fn seconds(s: f64) -> Result<DeltaT, SunError> {
        if s.is_finite() && (-10_000.0..=10_000.0).contains(&s) {
            Ok(DeltaT(s))
        } else {
            Err(SunError::DeltaT(s))
        }
    }

    /// The value in seconds.
    pub fn value(&self) -> f64 {
        self.0
    }
}

/// The default ΔT for an instant: `solar_positioning::delta_t::estimate_from_date` for its
/// UTC year and month (Espenak & Meeus' polynomials, refitted to IERS data from 2015; 69.2 s
/// in mid-2025).
pub fn default_delta_t(t: &DateTime<Utc>) -> Result<DeltaT, SunError> {
    use chrono::Datelike;
    solar_positioning::delta_t::estimate_from_date(t.year(), t.month())
        .map(DeltaT)
        .map_err(|e| SunError::Spa(e.to_string()))
}

/// Where the sun is at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    /// Degrees clockwise from north, [0, 360).
    pub azimuth_deg: f64,
    /// Topocentric zenith angle with refraction, degrees.
    pub zenith_deg: f64,
    /// 90° − zenith.
    pub elevation_deg: f64,
    /// Zenith angle without refraction, degrees.
    pub geometric_zenith_deg: f64,
    /// The sun is up (unrefracted centre above [`SUNRISE_ELEVATION_DEG`]).
    pub up: bool,
}

/// The sun's position seen from `site` at the instant `t`.
pub fn position(
    site: &Site,
    t: &DateTime<Utc>,
    delta_t: DeltaT,
    atmosphere: &Atmosphere,
) -> Result<SunPosition, SunError> {
    let jd = JulianDate::from_datetime(t, delta_t.0).map_err(|e| SunError::Spa(e.to_string()))?;
    position_at_julian(site, jd, atmosphere)
}

fn position_at_julian(
    site: &Site,
    jd: JulianDate,
    atmosphere: &Atmosphere,
) -> Result<SunPosition, SunError> {
    let spa_err = |e: solar_positioning::Error| SunError::Spa(e.to_string());
    // SPA (not Grena3): SolarPositions::new() selects NREL's algorithm.
    let prepared = SolarPositions::new()
        .for_time_from_julian(jd)
        .map_err(spa_err)?;
    let geometric = prepared
        .at(site.location(), site.elevation_m, None)
        .map_err(spa_err)?;
    let refracted = prepared
        .at(
            site.location(),
            site.elevation_m,
            Some(atmosphere.correction()?),
        )
        .map_err(spa_err)?;
    let zenith = refracted.zenith_angle();
    Ok(SunPosition {
        azimuth_deg: refracted.azimuth(),
        zenith_deg: zenith,
        elevation_deg: 90.0 - zenith,
        geometric_zenith_deg: geometric.zenith_angle(),
        up: 90.0 - geometric.zenith_angle() > SUNRISE_ELEVATION_DEG,
    })
}

/// Sunrise and sunset on a local calendar day.
#[derive(Debug, Clone, PartialEq)]
pub enum Daylight {
    /// The sun rises and/or sets on this day (either may be missing when the day holds only
    /// one of them, near the polar circles).
    Regular {
        /// Sunrise(s) on the day, local time.
        rises: Vec<DateTime<FixedOffset>>,
        /// Sunset(s) on the day, local time.
        sets: Vec<DateTime<FixedOffset>>,
    },
    /// The sun stays up all day.
    PolarDay,
    /// The sun stays down all day.
    PolarNight,
}

/// Sunrise and sunset on `date` as a clock at `offset` shows it (SPA's events, horizon
/// −0.83337°).
pub fn daylight(
    site: &Site,
    date: NaiveDate,
    offset: FixedOffset,
    delta_t: DeltaT,
) -> Result<Daylight, SunError> {
    let events = SolarEvents::new()
        .for_date(
            date,
            &offset,
            site.location(),
            delta_t.0,
            Horizon::SunriseSunset,
        )
        .map_err(|e| SunError::Spa(e.to_string()))?;
    if events.rises.is_empty() && events.sets.is_empty() {
        if events.always_above() {
            return Ok(Daylight::PolarDay);
        }
        if events.always_below() {
            return Ok(Daylight::PolarNight);
        }
    }
    let local = |t: &DateTime<FixedOffset>| t.with_timezone(&offset);
    Ok(Daylight::Regular {
        rises: events.rises.iter().map(local).collect(),
        sets: events.sets.iter().map(local).collect(),
    })
}

/// The sample times of a day: `from` to `to` (inclusive when it falls on the grid) every
/// `every`, on the clock at `offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DayGrid {
    /// The local calendar date.
    pub date: NaiveDate,
    /// The local clock's offset from UTC.
    pub offset: FixedOffset,
    /// First sample, local clock time.
    pub from: NaiveTime,
    /// Last sample at or before this local clock time.
    pub to: NaiveTime,
    /// Step, at least one second.
    pub every: Duration,
}

/// Most samples a grid may hold (a day at one-second steps).
pub const MAX_SAMPLES: usize = 86_401;

impl DayGrid {
    /// A grid, validated: `every` ≥ 1 s, `to` not before `from`.
    pub fn new(
        date: NaiveDate,
        offset: FixedOffset,
        from: NaiveTime,
        to: NaiveTime,
        every: Duration,
    ) -> Result<DayGrid, SunError> {
        if every < Duration::seconds(1) {
            return Err(SunError::Time(format!(
                "the step must be at least 1 s, got {} s",
                every.num_seconds()
            )));
        }
        if to < from {
            return Err(SunError::Time(format!(
                "the day's samples end ({}) before they start ({})",
                to.format("%H:%M"),
                from.format("%H:%M")
            )));
        }
        Ok(DayGrid {
            date,
            offset,
            from,
            to,
            every,
        })
    }

    /// The local sample times.
    pub fn times(&self) -> Vec<DateTime<FixedOffset>> {
        let start = self.date.and_time(self.from);
        let end = self.date.and_time(self.to);
        let mut out = Vec::new();
        let mut t = start;
        while t <= end && out.len() < MAX_SAMPLES {
            // A fixed offset maps every local time to exactly one instant.
            if let Some(local) = self.offset.from_local_datetime(&t).single() {
                out.push(local);
            }
            t += self.every;
        }
        out
    }
}

/// One sample of a day.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Local time.
    pub time: DateTime<FixedOffset>,
    /// The sun there and then.
    pub sun: SunPosition,
}

/// The sun at every time of `grid`. `delta_t` `None` takes [`default_delta_t`] of the first
/// sample (ΔT changes by well under a second over a day).
pub fn day(
    site: &Site,
    grid: &DayGrid,
    delta_t: Option<DeltaT>,
    atmosphere: &Atmosphere,
) -> Result<(DeltaT, Vec<Sample>), SunError> {
    let times = grid.times();
    let dt = match (delta_t, times.first()) {
        (Some(d), _) => d,
        (None, Some(t)) => default_delta_t(&t.with_timezone(&Utc))?,
        (None, None) => DeltaT(0.0),
    };
    let samples = times
        .into_iter()
        .map(|time| {
            position(site, &time.with_timezone(&Utc), dt, atmosphere)
                .map(|sun| Sample { time, sun })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((dt, samples))
}

// ------------------------------------------------------------------------------ parsing

/// Parses an RFC 3339 instant, e.g. `2025-06-21T12:00:00-04:00` (the offset is required;
/// `Z` is UTC; seconds may be omitted).
pub fn parse_instant(text: &str) -> Result<DateTime<FixedOffset>, SunError> {
    let t = text.trim();
    let bad = |why: &str| {
        SunError::Time(format!(
            "'{text}' is not an RFC 3339 time ({why}); expected e.g. 2025-06-21T12:30:00-04:00 or 2025-06-21T16:30Z"
        ))
    };
    if let Ok(d) = DateTime::parse_from_rfc3339(t) {
        return Ok(d);
    }
    // Without seconds: insert ":00" after HH:MM.
    if let Some(pos) = t.find(['T', 't', ' ']) {
        let (date, rest) = t.split_at(pos + 1);
        if rest.len() >= 5
            && rest
                .as_bytes()
                .get(5)
                .is_none_or(|b| !b.is_ascii_digit() && *b != b':')
        {
            let with = format!("{date}{}:00{}", &rest[..5], &rest[5..]);
            if let Ok(d) = DateTime::parse_from_rfc3339(&with) {
                return Ok(d);
            }
        }
    }
    // Say which part is wrong.
    let date_part = t.get(..10).unwrap_or(t);
    if NaiveDate::parse_from_str(date_part, "%Y-%m-%d").is_err() {
        return Err(bad("no valid date YYYY-MM-DD"));
    }
    if !(t.ends_with(['Z', 'z']) || t.rfind(['+', '-']).is_some_and(|p| p > 10)) {
        return Err(bad("it needs an offset: Z or ±HH:MM"));
    }
    Err(bad("no valid time of day and offset"))
}

/// Parses a calendar date `YYYY-MM-DD` (it must exist: no 2025-02-29).
pub fn parse_date(text: &str) -> Result<NaiveDate, SunError> {
    NaiveDate::parse_from_str(text.trim(), "%Y-%m-%d").map_err(|_| {
        SunError::Time(format!(
            "'{text}' is not a calendar date; expected YYYY-MM-DD, e.g. 2025-06-21"
        ))
    })
}

/// Parses a UTC offset `±HH:MM` (also `Z`, `UTC`, `±HH`), within ±18:00.
pub fn parse_offset(text: &str) -> Result<FixedOffset, SunError> {
    let t = text.trim();
    let bad = || {
        SunError::Time(format!(
            "'{text}' is not a UTC offset; expected ±HH:MM within ±18:00 (e.g. -04:00, +05:30) or Z"
        ))
    };
    if t.eq_ignore_ascii_case("z") || t.eq_ignore_ascii_case("utc") {
        return FixedOffset::east_opt(0).ok_or_else(bad);
    }
    let sign = match t.as_bytes().first() {
        Some(b'+') => 1,
        Some(b'-') => -1,
        _ => return Err(bad()),
    };
    let rest = &t[1..];
    let (h, m) = match rest.split_once(':') {
        Some((h, m)) => (h, m),
        None if rest.len() == 4 => rest.split_at(2),
        None => (rest, "00"),
    };
    let digits = |s: &str| s.len() == 2 && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(h) || !digits(m) {
        return Err(bad());
    }
    let (h, m): (i32, i32) = (h.parse().map_err(|_| bad())?, m.parse().map_err(|_| bad())?);
    if m >= 60 || h * 60 + m > 18 * 60 {
        return Err(bad());
    }
    FixedOffset::east_opt(sign * (h * 3600 + m * 60)).ok_or_else(bad)
}

/// Parses a clock time `HH:MM` or `HH:MM:SS` (00:00 … 23:59:59).
pub fn parse_clock(text: &str) -> Result<NaiveTime, SunError> {
    let t = text.trim();
    NaiveTime::parse_from_str(t, "%H:%M:%S")
        .or_else(|_| NaiveTime::parse_from_str(t, "%H:%M"))
        .map_err(|_| {
            SunError::Time(format!(
                "'{text}' is not a clock time; expected HH:MM in 00:00 … 23:59 (e.g. 09:00)"
            ))
        })
}

/// Parses a duration: a whole number with a unit, `s`, `m`, `h`, or a sum such as `1h30m`
/// (at least 1 s, at most 24 h).
pub fn parse_duration(text: &str) -> Result<Duration, SunError> {
    let t = text.trim();
    let bad = |why: &str| {
        SunError::Time(format!(
            "'{text}' is not a duration ({why}); expected a whole number with a unit s, m or h, e.g. 30s, 10m, 1h30m, from 1 s to 24 h"
        ))
    };
    if t.is_empty() {
        return Err(bad("empty"));
    }
    let mut total: i64 = 0;
    let mut num = String::new();
    for c in t.chars() {
        if c.is_ascii_digit() {
            num.push(c);
            continue;
        }
        let unit = match c {
            's' | 'S' => 1,
            'm' | 'M' => 60,
            'h' | 'H' => 3600,
            _ => return Err(bad("unknown character")),
        };
        if num.is_empty() || num.len() > 6 {
            return Err(bad("a unit needs a whole number before it"));
        }
        total += num.parse::<i64>().map_err(|_| bad("number"))? * unit;
        num.clear();
    }
    if !num.is_empty() {
        return Err(bad("the last number has no unit"));
    }
    if total == 0 {
        return Err(bad("it is zero: samples would never advance"));
    }
    if total > 86_400 {
        return Err(bad("longer than a day"));
    }
    Ok(Duration::seconds(total))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_parse_and_zero_is_refused() {
        assert_eq!(parse_duration("10m").unwrap(), Duration::minutes(10));
        assert_eq!(parse_duration("1h30m").unwrap(), Duration::minutes(90));
        assert_eq!(parse_duration("45s").unwrap(), Duration::seconds(45));
        for bad in [
            "0", "0m", "0s0m", "10", "m", "-5m", "1.5h", "", "25h", "10x",
        ] {
            assert!(parse_duration(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn offsets_clocks_dates_and_instants_parse_or_say_why_not() {
        assert_eq!(parse_offset("-04:00").unwrap().local_minus_utc(), -4 * 3600);
        assert_eq!(parse_offset("+05:30").unwrap().local_minus_utc(), 19_800);
        assert_eq!(parse_offset("Z").unwrap().local_minus_utc(), 0);
        assert_eq!(parse_offset("+0530").unwrap().local_minus_utc(), 19_800);
        for bad in ["04:00", "+19:00", "+05:60", "EST", "+5", ""] {
            assert!(parse_offset(bad).is_err(), "{bad}");
        }
        assert!(parse_clock("09:00").is_ok() && parse_clock("23:59:59").is_ok());
        for bad in ["24:00", "9", "12:60", "noon"] {
            assert!(parse_clock(bad).is_err(), "{bad}");
        }
        assert!(parse_date("2024-02-29").is_ok());
        for bad in ["2025-02-29", "2025-13-01", "21/06/2025"] {
            assert!(parse_date(bad).is_err(), "{bad}");
        }
        let t = parse_instant("2025-06-21T12:30-04:00").unwrap();
        assert_eq!(t, parse_instant("2025-06-21T16:30:00Z").unwrap());
        for bad in [
            "2025-06-21T12:30",
            "2025-02-30T12:00:00Z",
            "yesterday",
            "2025-06-21T25:00Z",
        ] {
            assert!(parse_instant(bad).is_err(), "{bad}");
        }
    }
}

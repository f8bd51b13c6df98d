//! EnergyPlus weather files (EPW): the location and the hourly solar columns daylight
//! needs. Eight header lines (the first is `LOCATION`), then one row per hour: 8,760 rows,
//! or 8,784 in a leap year. Every error names the line (1-based) and, for a value, the
//! field.
//!
//! Fields read (1-based): 1 year, 2 month, 3 day, 4 hour (1–24: the hour ending then),
//! 8 dew point temperature (°C, 99.9 missing),
//! 14 global horizontal radiation, 15 direct normal radiation, 16 diffuse horizontal
//! radiation (Wh/m² over the hour, i.e. mean W/m²), 17 global horizontal illuminance,
//! 18 direct normal illuminance, 19 diffuse horizontal illuminance (lux). The EPW marks a
//! missing illuminance with 999999; such a value is read as absent (`None`), and a
//! missing radiation (9999) is an error, since the sky cannot be built without it.

/// Largest EPW text read, bytes (an 8,784-row file is about 1.6 MB).
pub const MAX_EPW_BYTES: usize = 16 << 20;
/// Longest line, bytes.
const MAX_LINE: usize = 64 << 10;

/// The site line of an EPW file.
#[derive(Debug, Clone, PartialEq)]
pub struct Location {
    pub city: String,
    /// Degrees north.
    pub latitude_deg: f64,
    /// Degrees east.
    pub longitude_deg: f64,
    /// Hours east of UTC.
    pub timezone_h: f64,
    /// Metres.
    pub elevation_m: f64,
}

/// One hour of weather.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hour {
    pub month: u32,
    pub day: u32,
    /// 1–24, the hour ending at this time (1 = 00:00–01:00).
    pub hour: u32,
    /// W/m² (mean over the hour).
    pub irradiance: Solar<f64>,
    /// Lux; each None when the file marks it missing.
    pub illuminance: Solar<Option<f64>>,
    /// Dew point temperature, °C; None when the file marks it missing (99.9).
    pub dew_point_c: Option<f64>,
}

/// The three solar components an EPW row gives of both irradiance and illuminance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solar<T> {
    pub global_horizontal: T,
    pub direct_normal: T,
    pub diffuse_horizontal: T,
}

/// A weather file.
#[derive(Debug, Clone)]
pub struct Weather {
    pub location: Location,
    pub hours: Vec<Hour>,
}

fn field<'a>(fields: &[&'a str], k: usize, line: usize) -> Result<&'a str, String> {
    fields.get(k - 1).map(|s| s.trim()).ok_or_else(|| {
        format!(
            "line {line}: field {k} is missing ({} fields)",
            fields.len()
        )
    })
}

fn number(fields: &[&str], k: usize, line: usize, what: &str) -> Result<f64, String> {
    let s = field(fields, k, line)?;
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!(
            "line {line}: field {k} ({what}) is not a number: '{}'",
            short(s)
        )),
    }
}

fn short(s: &str) -> String {
    s.chars().take(40).collect()
}

/// Refuses a weather file of `len` bytes over [`MAX_EPW_BYTES`].
fn check_size(len: usize) -> Result<(), String> {
    if len > MAX_EPW_BYTES {
        return Err(format!(
            "the weather file is larger than {} MiB",
            MAX_EPW_BYTES >> 20
        ));
    }
    Ok(())
}

/// Parses an EPW file's bytes. Header comments are often Latin-1, not UTF-8: invalid
/// bytes are read as U+FFFD (the fields relight reads are ASCII).
pub fn parse_bytes(bytes: &[u8]) -> Result<Weather, String> {
    check_size(bytes.len())?;
    parse(&String::from_utf8_lossy(bytes))
}

/// Parses an EPW file's text.
pub fn parse(text: &str) -> Result<Weather, String> {
    check_size(text.len())?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let (n, first) = lines.next().ok_or("the weather file is empty")?;
    let location = parse_location(first, n)?;
    // The other seven header lines.
    for _ in 0..7 {
        lines
            .next()
            .ok_or("the weather file ends inside its header")?;
    }
    let mut hours = Vec::with_capacity(8784);
    for (n, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        if l.len() > MAX_LINE {
            return Err(format!("line {n}: longer than {} KiB", MAX_LINE >> 10));
        }
        if hours.len() == 8784 {
            return Err(format!("line {n}: more than 8,784 hourly rows"));
        }
        let row = Row {
            fields: l.split(',').collect(),
            line: n,
        };
        hours.push(row.hour()?);
    }
    if hours.len() != 8760 && hours.len() != 8784 {
        return Err(format!(
            "the weather file has {} hourly rows; a year has 8,760 (8,784 in a leap year)",
            hours.len()
        ));
    }
    Ok(Weather { location, hours })
}

/// The `LOCATION` line `l`, line `n` of the file.
fn parse_location(l: &str, n: usize) -> Result<Location, String> {
    let loc: Vec<&str> = l.split(',').collect();
    if loc.first().map(|s| s.trim()) != Some("LOCATION") {
        return Err(format!("line {n}: an EPW file starts with a LOCATION line"));
    }
    let location = Location {
        city: field(&loc, 2, n)?.to_string(),
        latitude_deg: number(&loc, 7, n, "latitude")?,
        longitude_deg: number(&loc, 8, n, "longitude")?,
        timezone_h: number(&loc, 9, n, "time zone")?,
        elevation_m: number(&loc, 10, n, "elevation")?,
    };
    if !(-90.0..=90.0).contains(&location.latitude_deg)
        || !(-180.0..=180.0).contains(&location.longitude_deg)
        || !(-12.0..=14.0).contains(&location.timezone_h)
    {
        return Err(format!(
            "line {n}: latitude, longitude or time zone out of range"
        ));
    }
    Ok(location)
}

/// The fields of one hourly row, and its line number.
struct Row<'a> {
    fields: Vec<&'a str>,
    line: usize,
}

impl Row<'_> {
    fn hour(&self) -> Result<Hour, String> {
        Ok(Hour {
            month: self.int(2, "month", 1, 12)?,
            day: self.int(3, "day", 1, 31)?,
            hour: self.int(4, "hour", 1, 24)?,
            irradiance: self.solar(14, "radiation", Row::radiation)?,
            illuminance: self.solar(17, "illuminance", Row::lux)?,
            dew_point_c: self.dew_point()?,
        })
    }

    /// Fields `k..k + 3`, the global horizontal, direct normal and diffuse horizontal
    /// `what`, each read by `read`.
    fn solar<T>(
        &self,
        k: usize,
        what: &str,
        read: impl Fn(&Self, usize, &str) -> Result<T, String>,
    ) -> Result<Solar<T>, String> {
        Ok(Solar {
            global_horizontal: read(self, k, &format!("global horizontal {what}"))?,
            direct_normal: read(self, k + 1, &format!("direct normal {what}"))?,
            diffuse_horizontal: read(self, k + 2, &format!("diffuse horizontal {what}"))?,
        })
    }

    /// Whole number field `k`, within `lo..=hi`.
    fn int(&self, k: usize, what: &str, lo: u32, hi: u32) -> Result<u32, String> {
        let n = self.line;
        let s = field(&self.fields, k, n)?;
        match s.parse::<u32>() {
            Ok(x) if (lo..=hi).contains(&x) => Ok(x),
            _ => Err(format!(
                "line {n}: field {k} ({what}) must be {lo}–{hi}: '{}'",
                short(s)
            )),
        }
    }

    /// Radiation field `k`, Wh/m²; missing (9999) is an error.
    fn radiation(&self, k: usize, what: &str) -> Result<f64, String> {
        let n = self.line;
        let x = number(&self.fields, k, n, what)?;
        if !(0.0..9999.0).contains(&x) {
            return Err(format!(
                "line {n}: field {k} ({what}) is missing or out of range: {x}"
            ));
        }
        Ok(x)
    }

    /// Illuminance field `k`, lux; None when missing (999999).
    fn lux(&self, k: usize, what: &str) -> Result<Option<f64>, String> {
        let n = self.line;
        let x = number(&self.fields, k, n, what)?;
        if x >= 999_999.0 {
            return Ok(None);
        }
        if !(0.0..=200_000.0).contains(&x) {
            return Err(format!("line {n}: field {k} ({what}) out of range: {x}"));
        }
        Ok(Some(x))
    }

    /// The dew point temperature (field 8), °C; None when missing (99.9).
    fn dew_point(&self) -> Result<Option<f64>, String> {
        let n = self.line;
        let x = number(&self.fields, 8, n, "dew point temperature")?;
        if x >= 99.9 {
            Ok(None)
        } else if (-90.0..70.0).contains(&x) {
            Ok(Some(x))
        } else {
            Err(format!(
                "line {n}: field 8 (dew point temperature) out of range: {x}"
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{parse, parse_bytes};

    const MANNHEIM_BYTES: &[u8] = include_bytes!("../../tests/data/weather/mannheim.epw");
    const CHICAGO: &[u8] = include_bytes!("../../tests/data/weather/chicago.epw");

    /// Annual global horizontal irradiation, kWh/m².
    fn annual_kwh(w: &super::Weather) -> f64 {
        w.hours
            .iter()
            .map(|h| h.irradiance.global_horizontal)
            .sum::<f64>()
            / 1000.0
    }

    #[test]
    fn real_weather_files_parse_with_plausible_totals() {
        let w = parse_bytes(MANNHEIM_BYTES).unwrap();
        assert_eq!(w.location.city, "Mannheim");
        assert_eq!(
            (
                w.location.latitude_deg,
                w.location.longitude_deg,
                w.location.timezone_h
            ),
            (49.52, 8.55, 1.0)
        );
        assert_eq!(w.hours.len(), 8760);
        assert_eq!(
            (w.hours[0].month, w.hours[0].day, w.hours[0].hour),
            (1, 1, 1)
        );
        // Annual global horizontal irradiation, kWh/m²: central Europe receives 1000–1300.
        let kwh = annual_kwh(&w);
        assert!((1000.0..1300.0).contains(&kwh), "{kwh} kWh/m²");
        let c = parse_bytes(CHICAGO).unwrap();
        assert!((c.location.latitude_deg - 41.98).abs() < 0.01 && c.location.timezone_h == -6.0);
        let kwh = annual_kwh(&c);
        assert!((1200.0..1600.0).contains(&kwh), "{kwh} kWh/m²");
        // Luminous efficacy of daylight, global: about 100–125 lm/W in the yearly mean.
        let (lux, wm2) = c.hours.iter().fold((0.0, 0.0), |(a, b), h| {
            (
                a + h.illuminance.global_horizontal.unwrap_or(0.0),
                b + h.irradiance.global_horizontal,
            )
        });
        assert!((95.0..130.0).contains(&(lux / wm2)), "{} lm/W", lux / wm2);
    }

    #[test]
    fn broken_rows_name_their_line_and_field() {
        let text = String::from_utf8_lossy(MANNHEIM_BYTES);
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let mut f: Vec<String> = lines[100].split(',').map(String::from).collect();
        f[14] = "abc".into();
        lines[100] = f.join(",");
        let e = parse(&lines.join("\n")).unwrap_err();
        assert!(e.contains("line 101") && e.contains("field 15"), "{e}");
        let short: Vec<&str> = text.lines().take(500).collect();
        let e = parse(&short.join("\n")).unwrap_err();
        assert!(e.contains("492 hourly rows"), "{e}");
        assert!(parse("").is_err());
        assert!(parse("hello\n").unwrap_err().contains("LOCATION"));
    }
}

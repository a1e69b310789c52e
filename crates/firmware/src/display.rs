//! Four-digit seven-segment display content (TM1637 order).
//!
//! A digit is one byte: bit 0 = segment a (top), 1 = b (top right), 2 = c (bottom right),
//! 3 = d (bottom), 4 = e (bottom left), 5 = f (top left), 6 = g (middle), 7 = decimal point.
//! Digits are ordered left to right, the order a TM1637 takes them.
//!
//! What the controller shows (see [`Controller::poll_display`](crate::Controller::poll_display)):
//! the trunk state (`F-P `, `d-F ` …, [`geometry::TrunkState::display_text`]), `E-xx` for a
//! fault, the task while a manual step waits for a person ([`task`]: `H-Pb`, `H-Ft`, `H-Fb`),
//! or the pressure while the show-pressure button is held.

use protocol::ManualTask;

/// Segment bit of the decimal point.
pub const DP: u8 = 0x80;

/// The segments of one ASCII character; characters that cannot be drawn are blank.
pub const fn glyph(c: u8) -> u8 {
    match c {
        b'0' | b'O' => 0x3F,
        b'1' => 0x06,
        b'2' => 0x5B,
        b'3' => 0x4F,
        b'4' => 0x66,
        b'5' | b'S' | b's' => 0x6D,
        b'6' => 0x7D,
        b'7' => 0x07,
        b'8' => 0x7F,
        b'9' => 0x6F,
        b'A' | b'a' => 0x77,
        b'b' | b'B' => 0x7C,
        b'C' => 0x39,
        b'c' => 0x58,
        b'd' | b'D' => 0x5E,
        b'E' | b'e' => 0x79,
        b'F' | b'f' => 0x71,
        b'H' => 0x76,
        b'h' => 0x74,
        b'L' | b'l' => 0x38,
        b'n' | b'N' => 0x54,
        b'o' => 0x5C,
        b'P' | b'p' => 0x73,
        b'r' | b'R' => 0x50,
        b't' | b'T' => 0x78,
        b'U' => 0x3E,
        b'u' => 0x1C,
        b'-' => 0x40,
        b'_' => 0x08,
        _ => 0x00,
    }
}

/// The segments of a text of up to four characters (shorter texts are padded with blanks).
pub fn text(s: &str) -> [u8; 4] {
    let mut out = [0u8; 4];
    for (o, c) in out.iter_mut().zip(s.bytes()) {
        *o = glyph(c);
    }
    out
}

/// What a manual step asks a person to do, as a code: `H-` (by hand) and the task — `Pb` pack
/// the bottom module, `Ft` fold the top module, `Fb` fold the bottom module.
pub fn task(t: ManualTask) -> [u8; 4] {
    text(match t {
        ManualTask::PackBottomModule => "H-Pb",
        ManualTask::FoldTopModule => "H-Ft",
        ManualTask::FoldBottomModule => "H-Fb",
    })
}

/// `E-xx` for a fault code (two decimal digits).
pub fn fault(code: u8) -> [u8; 4] {
    let code = code % 100;
    [
        glyph(b'E'),
        glyph(b'-'),
        glyph(b'0' + code / 10),
        glyph(b'0' + code % 10),
    ]
}

/// A pressure in kPa, right-aligned: one decimal below 100 (`12.5`, ` 0.0`, `-1.2`), whole
/// numbers from 100 (` 105`), `-Hi-`/`-Lo-` outside −99…9999 or when not finite.
pub fn pressure(kpa: f32) -> [u8; 4] {
    if !kpa.is_finite() || kpa >= 9999.5 {
        return text("-Hi-");
    }
    if kpa <= -9.95 {
        return text("-Lo-");
    }
    let mut out = [0u8; 4];
    if kpa.abs() < 99.95 {
        // Tenths, with the decimal point on the third digit.
        let tenths = libm::roundf(kpa.abs() * 10.0) as u32;
        let mut digits = [b' '; 4];
        digits[3] = b'0' + (tenths % 10) as u8;
        digits[2] = b'0' + ((tenths / 10) % 10) as u8;
        let tens = (tenths / 100) % 10;
        if tens > 0 {
            digits[1] = b'0' + tens as u8;
        }
        if kpa < 0.0 && tenths > 0 {
            let sign_at = if tens > 0 { 0 } else { 1 };
            digits[sign_at] = b'-';
        }
        for (o, d) in out.iter_mut().zip(digits) {
            *o = glyph(d);
        }
        out[2] |= DP;
    } else {
        let mut v = libm::roundf(kpa) as u32;
        for o in out.iter_mut().rev() {
            *o = glyph(b'0' + (v % 10) as u8);
            v /= 10;
            if v == 0 {
                break;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_texts_are_drawable() {
        for s in geometry::TrunkState::ALL {
            let seg = text(s.display_text());
            // Three drawn characters and a blank.
            assert!(seg[..3].iter().all(|&d| d != 0), "{s}");
            assert_eq!(seg[3], 0);
        }
        assert_eq!(text("F-P "), [0x71, 0x40, 0x73, 0x00]);
        assert_eq!(text("d-F "), [0x5E, 0x40, 0x71, 0x00]);
    }

    #[test]
    fn every_task_has_its_own_drawable_code() {
        let all = [
            ManualTask::PackBottomModule,
            ManualTask::FoldTopModule,
            ManualTask::FoldBottomModule,
        ];
        for (i, a) in all.iter().enumerate() {
            assert!(task(*a).iter().all(|&d| d != 0), "{a:?}");
            for b in &all[i + 1..] {
                assert_ne!(task(*a), task(*b));
            }
        }
        assert_eq!(task(ManualTask::PackBottomModule), [0x76, 0x40, 0x73, 0x7C]);
    }

    #[test]
    fn fault_codes_show_two_digits() {
        assert_eq!(fault(1), [0x79, 0x40, 0x3F, 0x06]);
        assert_eq!(fault(10), [0x79, 0x40, 0x06, 0x3F]);
    }

    #[test]
    fn pressure_formats() {
        assert_eq!(
            pressure(12.46),
            [0, glyph(b'1'), glyph(b'2') | DP, glyph(b'5')]
        );
        assert_eq!(pressure(0.0), [0, 0, glyph(b'0') | DP, glyph(b'0')]);
        assert_eq!(
            pressure(-1.2),
            [0, glyph(b'-'), glyph(b'1') | DP, glyph(b'2')]
        );
        assert_eq!(pressure(105.2), [0, glyph(b'1'), glyph(b'0'), glyph(b'5')]);
        assert_eq!(pressure(f32::NAN), text("-Hi-"));
        assert_eq!(pressure(-50.0), text("-Lo-"));
    }
}

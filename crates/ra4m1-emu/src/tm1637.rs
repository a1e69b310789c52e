//! A TM1637 four-digit LED driver on two port pins, decoded from the pin levels as the chip
//! does it (TM1637 data sheet): start = DIO falls while CLK is high, stop = DIO rises while CLK
//! is high; data bits are taken LSB first on each CLK rising edge; after the eighth bit the
//! chip pulls DIO low from the eighth falling edge to the ninth falling edge (the ACK).
//! Commands: 0x40/0x44 (data: auto-increment/fixed address), 0xC0 | addr (address, then digit
//! bytes), 0x80 | 0x08 (on) | brightness.

/// The display's state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tm1637 {
    /// Segment bytes of the six digit registers (the board uses the first four).
    pub digits: [u8; 6],
    /// Display on.
    pub on: bool,
    /// Brightness 0..=7.
    pub brightness: u8,
    /// Complete frames received.
    pub frames: u32,
    clk: bool,
    dio: bool,
    in_frame: bool,
    bit: u8,
    byte: u8,
    bytes_in_frame: u8,
    addr: u8,
    fixed: bool,
    /// The chip pulls DIO low (ACK).
    pub acking: bool,
}

impl Tm1637 {
    /// Idle lines (both high).
    pub fn new() -> Self {
        Self {
            clk: true,
            dio: true,
            ..Self::default()
        }
    }

    /// Feeds the line levels after a change (`dio` as the MCU leaves it, the chip's own pull
    /// excluded).
    pub fn update(&mut self, clk: bool, dio: bool) {
        let dio_seen = dio && !self.acking;
        if clk && self.clk && dio_seen != self.dio {
            if !dio_seen {
                self.in_frame = true;
                self.bit = 0;
                self.byte = 0;
                self.bytes_in_frame = 0;
            } else {
                self.in_frame = false;
                self.frames += 1;
            }
        } else if self.in_frame && clk && !self.clk {
            // Rising edge: a data bit (or the ACK clock).
            if self.bit < 8 {
                if dio {
                    self.byte |= 1 << self.bit;
                }
                self.bit += 1;
            }
        } else if self.in_frame && !clk && self.clk {
            // Falling edge: after bit 8 the ACK starts; after the ACK clock it ends.
            if self.acking {
                self.acking = false;
                self.bit = 0;
                self.byte = 0;
            } else if self.bit == 8 {
                self.acking = true;
                let b = self.byte;
                self.take(b);
            }
        }
        self.clk = clk;
        self.dio = dio && !self.acking;
    }

    fn take(&mut self, b: u8) {
        let first = self.bytes_in_frame == 0;
        self.bytes_in_frame = self.bytes_in_frame.saturating_add(1);
        if first {
            match b & 0xC0 {
                0x40 => self.fixed = b & 0x04 != 0,
                0xC0 => self.addr = b & 0x07,
                0x80 => {
                    self.on = b & 0x08 != 0;
                    self.brightness = b & 0x07;
                }
                _ => {}
            }
        } else if let Some(d) = self.digits.get_mut(usize::from(self.addr)) {
            *d = b;
            if !self.fixed {
                self.addr += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn send(tm: &mut Tm1637, bytes: &[u8]) {
        let (mut clk, mut dio) = (true, true);
        let mut set = |tm: &mut Tm1637, c: bool, d: bool| {
            clk = c;
            dio = d;
            tm.update(clk, dio);
        };
        set(tm, true, false); // start
        set(tm, false, false);
        for &b in bytes {
            for i in 0..8 {
                set(tm, false, b & (1 << i) != 0);
                set(tm, true, b & (1 << i) != 0);
            }
            set(tm, false, true);
            assert!(tm.acking, "ACK after byte {b:#x}");
            set(tm, true, true);
            set(tm, false, true);
            assert!(!tm.acking);
        }
        set(tm, false, false);
        set(tm, true, false);
        set(tm, true, true); // stop
    }

    #[test]
    fn decodes_a_frame_with_acks() {
        let mut tm = Tm1637::new();
        send(&mut tm, &[0x40]);
        send(&mut tm, &[0xC0, 0x3F, 0x06, 0x5B, 0x4F]);
        send(&mut tm, &[0x8C]);
        assert_eq!(&tm.digits[..4], &[0x3F, 0x06, 0x5B, 0x4F]);
        assert!(tm.on);
        assert_eq!(tm.brightness, 4);
        assert_eq!(tm.frames, 3);
    }
}

//! On-target tests of the board shell that need a stimulus: **the stimulus fixture** must be
//! fitted (the emulator's runner, `ra4m1-run`, fits it itself):
//!
//! | stimulus | UNO R4 Minima | UNO R4 WiFi |
//! |---|---|---|
//! | SCI9 loopback (TXD9 P109 → RXD9 P110) | jumper D11–D12 | SCI9 is the ESP32-S3 bridge's: echo on the host, `socat /dev/ttyACM0,b115200,raw,echo=0 EXEC:cat` |
//! | A0 (P014, AN009) at 0 V | jumper A0–GND | jumper A0–GND |
//! | A1 (P000, AN000) at 3.3 V | jumper A1–3V3 | jumper A1–3V3 |
//! | A2 (P001, AN001) at 5 V | jumper A2–5V | jumper A2–5V |
//! | a TM1637 display module | CLK to D13 (P111), DIO to D1 (P302), VCC 5V, GND | CLK to D6 (P111), DIO to D1 (P302), VCC 5V, GND |
//!
//! ```text
//! cargo test-board-fixture                                      # probe-rs
//! CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER=ra4m1-run cargo test-board-fixture
//! ```
//! Everything that needs nothing attached is in `tests/board.rs`.
#![no_std]
#![no_main]

use firmware::board;
mod on_target;

#[cfg(test)]
#[embedded_test::tests]
mod tests {
    use embedded_io::{Read as _, ReadReady as _, Write as _};
    use firmware::hw::AnalogInput as _;
    use protocol::messages::RequestBody;
    use protocol::{encode, FrameDecoder, Request, MAX_FRAME_LEN};

    use crate::board::gpio::{OpenDrain, Output};
    use crate::board::{adc, tm1637, uart};
    use crate::on_target::{self, Board};
    use firmware::hw::SegmentDisplay as _;
    use firmware::pins;

    #[init]
    fn init() -> Board {
        on_target::init()
    }

    /// Needs the SCI9 loopback. A protocol frame sent on SCI9 comes back whole through the
    /// receive interrupt's ring and decodes to the request sent, within 50 ms.
    #[test]
    fn sci9_sends_and_receives_a_frame(b: Board) {
        let mut link = uart::HostUart::new(b.clocks.pclka_hz, pins::HOST_TX, pins::HOST_RX);
        let request = Request {
            seq: 0x1234,
            session: 7,
            body: RequestBody::GetStatus,
        };
        let mut frame = [0u8; MAX_FRAME_LEN];
        let n = encode(&request, &mut frame).unwrap_or(0);
        assert!(n > 4, "encoded");
        // Whatever arrived before (line noise at start-up) is not ours.
        let mut junk = [0u8; 64];
        while link.read_ready().unwrap_or(false) {
            let _ = link.read(&mut junk);
        }
        let mut sent = 0;
        while sent < n {
            sent += link.write(&frame[sent..n]).unwrap_or(0);
        }
        let mut got = [0u8; MAX_FRAME_LEN];
        let mut len = 0;
        let t0 = on_target::ms();
        while len < n && on_target::ms().wrapping_sub(t0) < 50 {
            if link.read_ready().unwrap_or(false) {
                len += link.read(&mut got[len..n]).unwrap_or(0);
            }
        }
        assert_eq!(
            len, n,
            "{len} of {n} bytes came back in 50 ms: is the loopback fitted (docs/flashing.md)?"
        );
        assert_eq!(&got[..n], &frame[..n], "the bytes came back changed");
        let mut dec = FrameDecoder::default();
        let decoded = got[..n]
            .iter()
            .find_map(|&byte| dec.push::<Request>(byte))
            .and_then(Result::ok);
        assert_eq!(decoded, Some(request));
        assert_eq!(link.dropped(), 0, "receive errors or ring overflow");
    }

    /// Needs A0 at 0 V, A1 at 3.3 V, A2 at 5 V. The 14-bit ADC reads them against AVCC0 (the
    /// board's 5 V, 4.75–5.25 V from USB): A0 ≤ 1 % of full scale, A1 3.3/5 of it within the
    /// supply's and the 3V3 regulator's tolerance (0.61–0.71), A2 ≥ 98 %.
    #[test]
    fn the_adc_reads_known_voltages(_b: Board) {
        let mut a = adc::Adc::new();
        let read = |mut ch: adc::AnalogChannel| {
            let mut sum = 0u32;
            for _ in 0..8 {
                sum += u32::from(ch.read_raw().unwrap_or(u16::MAX));
            }
            sum / 8
        };
        let a0 = read(a.channel(pins::PRESSURE));
        let a1 = read(a.channel(pins::JOY_X));
        let a2 = read(a.channel(pins::JOY_Y));
        defmt::info!("A0 {=u32}, A1 {=u32}, A2 {=u32} of 16383", a0, a1, a2);
        let fs = u32::from(firmware::ADC_MAX);
        assert!(a0 <= fs / 100, "A0 = {a0}: is it jumpered to GND?");
        assert!(
            (fs * 61 / 100..=fs * 71 / 100).contains(&a1),
            "A1 = {a1}: is it jumpered to 3V3?"
        );
        assert!(a2 >= fs * 98 / 100, "A2 = {a2}: is it jumpered to 5V?");
    }

    /// Needs a TM1637 display module on D0/D1. A redraw goes out one byte per poll (seven:
    /// data command, address, four digits, display control) and the chip acknowledges every
    /// byte; the display then shows "8.8.8.8." at brightness 4 (look at it on a bench).
    #[test]
    fn the_tm1637_acknowledges_every_byte_of_a_redraw(_b: Board) {
        let mut d = tm1637::Tm1637::new(Output::new(pins::TM_CLK), OpenDrain::new(pins::TM_DIO), 4);
        assert_eq!(d.show([0xFF; 4]), Ok(()));
        for _ in 0..7 {
            d.poll();
        }
        assert_eq!(
            d.missed_acks, 0,
            "bytes not acknowledged: is the display on D0 (CLK) / D1 (DIO) with 5 V?"
        );
        // A second redraw: the bus was left idle.
        assert_eq!(d.show([0x3F, 0x06, 0x5B, 0x4F]), Ok(()));
        for _ in 0..7 {
            d.poll();
        }
        assert_eq!(d.missed_acks, 0, "second redraw");
    }
}

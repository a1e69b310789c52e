//! The pin map, in RA4M1 port/pin terms. The same binary runs on the UNO R4 Minima and WiFi:
//! every pin below reaches a header on both boards (the header labels differ between the two;
//! `docs/hardware.md` has both columns).

use super::gpio::PortPin;

/// Tendon servo 0: GTIOC7A (P304: D8 on both boards).
pub const SERVO0: PortPin = PortPin::new(3, 4);
/// Tendon servo 1: GTIOC7B (P303: D9 on both boards).
pub const SERVO1: PortPin = PortPin::new(3, 3);
/// Tendon servo 2: GTIOC5A (P101: A4/SDA on both boards).
pub const SERVO2: PortPin = PortPin::new(1, 1);

/// Inlet valve MOSFET gate, high = open (P104: WiFi D2, Minima D3).
pub const INLET: PortPin = PortPin::new(1, 4);
/// Exhaust valve MOSFET gate, high = open (P301: D0 on both boards). Not P111: the Minima's
/// bootloader fades P111 (its LED_BUILTIN) for as long as it stays in the bootloader after a
/// double reset, which on a valve vents the trunk (`docs/hardware.md`, "Bootloader").
pub const EXHAUST: PortPin = PortPin::new(3, 1);
/// Gripper driver, high = closed (P100: A5/SCL on both boards).
pub const GRIPPER: PortPin = PortPin::new(1, 0);

/// Step-up button to ground (P105: WiFi D3, Minima D2).
pub const BTN_UP: PortPin = PortPin::new(1, 5);
/// Step-down button to ground (P106: WiFi D4, Minima D6).
pub const BTN_DOWN: PortPin = PortPin::new(1, 6);
/// Gripper toggle button to ground (P107: WiFi D5, Minima D7).
pub const BTN_GRIPPER: PortPin = PortPin::new(1, 7);
/// Confirm button to ground (P103: WiFi D10, Minima D4).
pub const BTN_CONFIRM: PortPin = PortPin::new(1, 3);
/// Show-pressure button to ground (P002: A3 on both boards, used as a digital input).
pub const BTN_SHOW: PortPin = PortPin::new(0, 2);
/// E-stop, normally-closed contact to ground (P112: WiFi D7, Minima D10).
pub const BTN_ESTOP: PortPin = PortPin::new(1, 12);

/// TM1637 CLK (P111: WiFi D6, Minima D13 = LED_BUILTIN). The pin the bootloaders drive (low
/// while they wait, faded on the Minima while parked): on the display's clock that only
/// clocks nothing in (DIO stays high: no start condition).
pub const TM_CLK: PortPin = PortPin::new(1, 11);
/// TM1637 DIO (P302: D1 on both boards).
pub const TM_DIO: PortPin = PortPin::new(3, 2);

/// Host link TXD9 (P109: WiFi → ESP32-S3 USB bridge; Minima D11).
pub const HOST_TX: PortPin = PortPin::new(1, 9);
/// Host link RXD9 (P110: WiFi ← ESP32-S3 USB bridge; Minima D12).
pub const HOST_RX: PortPin = PortPin::new(1, 10);

/// Pressure sensor: AN009 (P014: A0 on both boards).
pub const PRESSURE: PortPin = PortPin::new(0, 14);
/// Pressure sensor ADC channel.
pub const PRESSURE_AN: u8 = 9;
/// Joystick x: AN000 (P000: A1 on both boards).
pub const JOY_X: PortPin = PortPin::new(0, 0);
/// Joystick x ADC channel.
pub const JOY_X_AN: u8 = 0;
/// Joystick y: AN001 (P001: A2 on both boards).
pub const JOY_Y: PortPin = PortPin::new(0, 1);
/// Joystick y ADC channel.
pub const JOY_Y_AN: u8 = 1;

//! Board support for the Arduino UNO R4 (Minima and WiFi): Renesas RA4M1 (R7FA4M1AB,
//! Cortex-M4F, 48 MHz). A thin layer: each module brings up one peripheral and implements the
//! [`crate::hw`] traits (or the embedded-hal / embedded-io ones) for it; all crane logic lives
//! in [`crate::Controller`].
//!
//! A module of the `firmware` library behind feature `board-uno-r4` (target
//! `thumbv7em-none-eabihf`), used by the `uno-r4` binary and the on-target suites
//! (`tests/board.rs`, `tests/board_fixture.rs`); the host never builds it. What is not register
//! access lives in the library for every target: the pin map ([`crate::pins`]: RA port/pin →
//! function, timer, ADC and SCI channels and GPIO modes paired by type; `docs/hardware.md` has
//! the wiring table)
//! and the data-flash record log ([`crate::flash_log`]), which the simulator's ELF wiring reads
//! too.
//!
//! Its small functions are `#[inline]`, so they are compiled into the binary as they were when
//! this tree was a module of the binary: across the crate boundary the optimiser, even with fat
//! LTO, folds them differently, and the image grew by 730 B (over the flash budget). The ones
//! the binary keeps out of line anyway (the flash sequencer's steps and `NorFlash` impl, the
//! UART rings and `clear_ir`, the PWM counter's start and duty write, the ADC read, the safe
//! state, the time base's reads, `wdt::feed`) stay plain: marked, they grew the image too.
//!
//! Map:
//! - [`regs`]: register access helpers over the `ra4m1-pac` PAC.
//! - [`clocks`]: HOCO 48 MHz and the bus dividers; reports the real frequencies.
//! - [`time`]: 1 ms SysTick time base (`now_ms`) and cycle-counter delays.
//! - [`gpio`]: push-pull outputs, pulled-up inputs and open-drain lines (embedded-hal
//!   `OutputPin`/`InputPin`), each from the pin map's typed line of its mode
//!   ([`crate::pins::Gpio`]).
//! - [`irq`]: clears the interrupt links and NVIC state the bootloader leaves.
//! - [`lvd`]: the brown-out reset (voltage monitor 1).
//! - [`pwm`]: GPT 16-bit timers at 50 Hz for the servos (embedded-hal `SetDutyCycle`), each
//!   output taken from the pin map's typed lines ([`crate::pins::Gtioc`]).
//! - [`adc`]: the 14-bit ADC (`hw::AnalogInput`), each channel taken from the pin map's typed
//!   inputs ([`crate::pins::Analog`]).
//! - [`uart`]: SCI9 host link with an interrupt-fed receive ring (embedded-io), on SCI9's typed
//!   lines of the pin map ([`crate::pins::Txd`], [`crate::pins::Rxd`]).
//! - [`wdt`]: the watchdog (WDT, register-start; the IWDT only if the option bytes started it).
//! - [`tm1637`]: the bit-banged four-digit display (`hw::SegmentDisplay`).
//! - [`dataflash`]: the data flash through the flash sequencer ([`crate::flash_log::NorFlash`]).
//! - [`stack`]: the stack guard (the CPU stack pointer monitor's NMI).
//! - [`safe`]: the safe state of every actuator line for the fault handlers, then the watchdog.
//! - [`log`]: the defmt macro shim (`log::info!` …) so nothing else names the backend.

pub mod adc;
pub mod clocks;
pub mod dataflash;
pub mod gpio;
pub mod irq;
pub mod log;
pub mod lvd;
pub mod pwm;
pub mod regs;
pub mod safe;
pub mod stack;
pub mod time;
pub mod tm1637;
pub mod uart;
pub mod wdt;

//! Board support for the Arduino UNO R4 (Minima and WiFi): Renesas RA4M1 (R7FA4M1AB,
//! Cortex-M4F, 48 MHz). A thin layer: each module brings up one peripheral and implements the
//! [`firmware::hw`] traits (or the embedded-hal / embedded-io ones) for it; all crane logic lives
//! in [`firmware::Controller`].
//!
//! Compiled only into the `uno-r4` binary (feature `board-uno-r4`, target
//! `thumbv7em-none-eabihf`); the host never builds it, except [`flash_log`], whose pure logic the
//! host tests (`tests/board_flash_log.rs`).
//!
//! Map:
//! - [`pins`]: the pin map (RA port/pin → function); `docs/hardware.md` has the wiring table.
//! - [`regs`]: register access helpers over the `ra4m1-pac` PAC.
//! - [`clocks`]: HOCO 48 MHz and the bus dividers; reports the real frequencies.
//! - [`time`]: 1 ms SysTick time base (`now_ms`) and cycle-counter delays.
//! - [`gpio`]: push-pull outputs and pulled-up inputs (embedded-hal `OutputPin`/`InputPin`).
//! - [`irq`]: clears the interrupt links and NVIC state the bootloader leaves.
//! - [`lvd`]: the brown-out reset (voltage monitor 1).
//! - [`pwm`]: GPT 16-bit timers at 50 Hz for the servos (embedded-hal `SetDutyCycle`).
//! - [`adc`]: the 14-bit ADC (`hw::AnalogInput`).
//! - [`uart`]: SCI9 host link with an interrupt-fed receive ring (embedded-io).
//! - [`wdt`]: the watchdog (WDT, register-start; the IWDT only if the option bytes started it).
//! - [`tm1637`]: the bit-banged four-digit display (`hw::SegmentDisplay`).
//! - [`dataflash`]: the data flash through the flash sequencer ([`flash_log::NorFlash`]).
//! - [`flash_log`]: the wear-aware record log (`hw::StateStore`).
//! - [`stack`]: the stack guard (the CPU stack pointer monitor's NMI).
//! - [`safe`]: the safe state of every actuator line for the fault handlers, then the watchdog.
//! - [`log`]: the defmt macro shim (`log::info!` …) so nothing else names the backend.

pub mod adc;
pub mod clocks;
pub mod dataflash;
pub mod flash_log;
pub mod gpio;
pub mod irq;
pub mod log;
pub mod lvd;
pub mod pins;
pub mod pwm;
pub mod regs;
pub mod safe;
pub mod stack;
pub mod time;
pub mod tm1637;
pub mod uart;
pub mod wdt;

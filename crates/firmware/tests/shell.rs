//! The shared loop body (`hw::Shell`) over mock embedded-hal / embedded-io parts: the
//! electrical conventions, boot from the store, the link, display and store plumbing.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::convert::Infallible;
use std::ops::RangeInclusive;
use std::rc::Rc;

use embedded_hal::digital::{ErrorKind, ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::SetDutyCycle;
use firmware::hw::{
    AnalogInput, PinInputs, PinOutputs, SegmentDisplay, ServoOutput, ServoPulse, Shell, StateStore,
};
use firmware::{Controller, CraneConfig, StoredState};
use geometry::TrunkState;
use host::{Reply, RequestId, Session, SessionEvent, Timing};
use protocol::{Event, Mode, RequestBody, ResponseBody, ResultCode};

#[derive(Clone, Default)]
struct Level(Rc<Cell<bool>>);

impl ErrorType for Level {
    type Error = Infallible;
}
impl OutputPin for Level {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.set(true);
        Ok(())
    }
}
impl InputPin for Level {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.get())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.get())
    }
}

/// An input pin that cannot be read.
struct Broken;
impl ErrorType for Broken {
    type Error = ErrorKind;
}
impl InputPin for Broken {
    fn is_high(&mut self) -> Result<bool, ErrorKind> {
        Err(ErrorKind::Other)
    }
    fn is_low(&mut self) -> Result<bool, ErrorKind> {
        Err(ErrorKind::Other)
    }
}

#[derive(Clone, Default)]
struct Pwm(Rc<Cell<u16>>);
impl embedded_hal::pwm::ErrorType for Pwm {
    type Error = Infallible;
}
impl SetDutyCycle for Pwm {
    fn max_duty_cycle(&self) -> u16 {
        40_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0.set(duty);
        Ok(())
    }
}

#[derive(Clone)]
struct Adc(Rc<Cell<u16>>);
impl AnalogInput for Adc {
    type Error = ();
    fn read_raw(&mut self) -> Result<u16, ()> {
        Ok(self.0.get())
    }
}

#[derive(Clone, Default)]
struct Display(Rc<RefCell<Vec<[u8; 4]>>>);
impl SegmentDisplay for Display {
    type Error = ();
    fn show(&mut self, segments: [u8; 4]) -> Result<(), ()> {
        self.0.borrow_mut().push(segments);
        Ok(())
    }
}

#[derive(Clone, Default)]
struct Store {
    bytes: Rc<RefCell<Option<[u8; 8]>>>,
    fail_saves: Rc<Cell<u32>>,
}
impl StateStore for Store {
    type Error = ();
    fn load(&mut self) -> Result<Option<StoredState>, ()> {
        match *self.bytes.borrow() {
            None => Ok(None),
            Some(b) => StoredState::from_bytes(&b).map_err(|_| ()),
        }
    }
    fn save(&mut self, s: &StoredState) -> Result<(), ()> {
        if self.fail_saves.get() > 0 {
            self.fail_saves.set(self.fail_saves.get() - 1);
            return Err(());
        }
        *self.bytes.borrow_mut() = Some(s.to_bytes());
        Ok(())
    }
}

#[derive(Clone, Default)]
struct Link {
    rx: Rc<RefCell<VecDeque<u8>>>,
    tx: Rc<RefCell<Vec<u8>>>,
}
impl embedded_io::ErrorType for Link {
    type Error = Infallible;
}
impl embedded_io::Read for Link {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut rx = self.rx.borrow_mut();
        let n = buf.len().min(rx.len());
        for b in buf.iter_mut().take(n) {
            *b = rx.pop_front().unwrap_or(0);
        }
        Ok(n)
    }
}
impl embedded_io::ReadReady for Link {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.borrow().is_empty())
    }
}
impl embedded_io::Write for Link {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        // A slow UART: at most 16 bytes per call.
        let n = buf.len().min(16);
        self.tx.borrow_mut().extend_from_slice(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
impl embedded_io::WriteReady for Link {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

struct Bench {
    pressure: Rc<Cell<u16>>,
    buttons: [Level; 6], // up, down, gripper, estop, confirm, show
    servo: [Pwm; 3],
    valves: [Level; 3], // inlet, exhaust, gripper
    display: Display,
    store: Store,
    link: Link,
}

type TheShell = Shell<
    PinInputs<Adc, Adc, Adc, Level, Level, Level, Level, Level, Level>,
    PinOutputs<Pwm, Pwm, Pwm, Level, Level, Level>,
    Display,
    Store,
    Link,
>;

fn bench() -> (Bench, TheShell) {
    let cfg = CraneConfig::default();
    let b = Bench {
        pressure: Rc::new(Cell::new(cfg.pressure_sensor.raw(0.0))),
        buttons: Default::default(),
        servo: Default::default(),
        valves: Default::default(),
        display: Display::default(),
        store: Store::default(),
        link: Link::default(),
    };
    // Released buttons read high (pull-ups); a released e-stop (closed contact) reads low.
    for (i, p) in b.buttons.iter().enumerate() {
        p.0.set(i != 3);
    }
    let centre = Rc::new(Cell::new(8192));
    let inputs = PinInputs {
        pressure: Adc(b.pressure.clone()),
        joystick_x: Adc(centre.clone()),
        joystick_y: Adc(centre),
        up: b.buttons[0].clone(),
        down: b.buttons[1].clone(),
        gripper: b.buttons[2].clone(),
        estop: b.buttons[3].clone(),
        confirm: b.buttons[4].clone(),
        show_pressure: b.buttons[5].clone(),
    };
    let pulse = ServoPulse::default();
    let outputs = PinOutputs {
        servos: (
            ServoOutput::new(b.servo[0].clone(), pulse),
            ServoOutput::new(b.servo[1].clone(), pulse),
            ServoOutput::new(b.servo[2].clone(), pulse),
        ),
        inlet: b.valves[0].clone(),
        exhaust: b.valves[1].clone(),
        gripper: b.valves[2].clone(),
    };
    let shell = Shell::new(
        inputs,
        outputs,
        b.display.clone(),
        b.store.clone(),
        b.link.clone(),
    );
    (b, shell)
}

/// The host on the link: the real host engine's session (crates/host), sending only what a
/// test asks for, and what it was told.
struct Host {
    session: Session,
    told: Vec<SessionEvent>,
}

impl Host {
    fn new() -> Self {
        let mut session = Session::new(Timing::standard(), 1);
        session.set_keepalive(false);
        Self {
            session,
            told: Vec::new(),
        }
    }

    /// Steps the shell through `ms`: the host's frames onto the link as it sends them, the
    /// device's bytes into the host as they come, the host's timers.
    fn run(
        &mut self,
        shell: &mut TheShell,
        ctl: &mut Controller,
        link: &Link,
        ms: RangeInclusive<u64>,
    ) {
        for now in ms {
            while let Some(frame) = self.session.poll_transmit() {
                link.rx.borrow_mut().extend(frame);
            }
            shell.step(ctl, now);
            let bytes = std::mem::take(&mut *link.tx.borrow_mut());
            self.session.handle_bytes(&bytes, now);
            if self.session.poll_timeout().is_some_and(|t| t <= now) {
                self.session.handle_timeout(now);
            }
            self.told
                .extend(std::iter::from_fn(|| self.session.poll_event()));
        }
    }

    /// The handshake at `now`, then a `DeclareState` of `state` once it is open; returns the
    /// request's id.
    fn connect_and_declare(
        &mut self,
        shell: &mut TheShell,
        ctl: &mut Controller,
        link: &Link,
        now: u64,
        state: &str,
    ) -> RequestId {
        self.session.connect(now);
        self.run(shell, ctl, link, now + 1..=now + 5);
        assert!(self.session.is_open(), "{:?}", self.told);
        self.session
            .request(RequestBody::DeclareState(state.parse().unwrap()), now + 5)
    }
}

#[test]
fn shell_boots_talks_and_drives_the_pins() {
    let (b, mut shell) = bench();
    let mut ctl = shell.boot(CraneConfig::default(), 0);
    assert_eq!(ctl.status().state, TrunkState::AS_MANUFACTURED);
    for now in 1..=10 {
        shell.step(&mut ctl, now);
    }
    let mut host = Host::new();
    let declare = host.connect_and_declare(&mut shell, &mut ctl, &b.link, 10, "F&F");
    host.run(&mut shell, &mut ctl, &b.link, 16..=200);
    // Two answers, the handshake's and the declaration's, each once.
    let answers: Vec<_> = host
        .told
        .iter()
        .filter(|ev| !matches!(ev, SessionEvent::Device(_)))
        .collect();
    assert_eq!(answers.len(), 2, "{answers:?}");
    assert!(matches!(answers[0], SessionEvent::Opened(info) if info.session == ctl.session()));
    assert_eq!(
        *answers[1],
        SessionEvent::Reply {
            id: declare,
            reply: Reply {
                result: ResultCode::Ok,
                body: ResponseBody::None
            }
        }
    );
    let stats = host.session.stats();
    assert_eq!(
        (stats.retries, stats.stale_responses, stats.frames_dropped),
        (0, 0, 0)
    );
    assert!(host
        .told
        .iter()
        .any(|ev| matches!(ev, SessionEvent::Device(Event::Heartbeat { .. }))));
    // Persisted through the store, as the board's data flash would.
    let stored = StoredState::from_bytes(&b.store.bytes.borrow().unwrap()).unwrap();
    assert_eq!(stored.map(|s| s.state), Some("F&F".parse().unwrap()));
    // Display: written once per change, TM1637 order.
    assert_eq!(
        *b.display.0.borrow(),
        [
            firmware::display::text("F-P "),
            firmware::display::text("F-F ")
        ]
    );
    // Servos at 0°: 500 µs of a 20 ms period = 2.5 % of 40 000.
    assert!(b.servo.iter().all(|s| s.0.get() == 1_000));
    // Valves closed; the gripper pin high: closed (it boots holding, fail-closed).
    assert!(!b.valves[0].0.get() && !b.valves[1].0.get());
    assert!(b.valves[2].0.get(), "gripper closed");

    // Step up (pin pulled low): the inlet valve pin goes high.
    b.buttons[0].0.set(false);
    for now in 201..=260 {
        shell.step(&mut ctl, now);
    }
    b.buttons[0].0.set(true);
    for now in 261..=300 {
        shell.step(&mut ctl, now);
    }
    assert_eq!(ctl.mode(), Mode::Running);
    assert!(b.valves[0].0.get(), "inlet open");
    // E-stop: its pin goes high (contact open) → latched, inlet pin low at once.
    b.buttons[3].0.set(true);
    shell.step(&mut ctl, 301);
    assert_eq!(ctl.mode(), Mode::EStop);
    assert!(!b.valves[0].0.get());
    // ... and the servo pulses stop (duty 0): limp servos push nothing.
    assert!(b.servo.iter().all(|s| s.0.get() == 0));
    assert_eq!(
        b.display.0.borrow().last().copied(),
        Some(firmware::display::fault(6))
    );
}

#[test]
fn shell_boots_unconfirmed_from_a_corrupt_store_and_retries_saves() {
    let (b, mut shell) = bench();
    *b.store.bytes.borrow_mut() = Some([b'Y', b'C', 1, 2, 1, 0, 0xAA, 0xBB]);
    let mut ctl = shell.boot(CraneConfig::default(), 0);
    let s = ctl.status();
    assert!(!s.state_confirmed);
    assert_eq!(s.faults, protocol::FaultCode::StateStorage.bit());
    assert_eq!(s.mode, Mode::Safe);
    // Recover locally: the confirm button resets the fault (the state stays unconfirmed).
    b.buttons[4].0.set(false);
    for now in 1..=40 {
        shell.step(&mut ctl, now);
    }
    b.buttons[4].0.set(true);
    assert_eq!(ctl.mode(), Mode::Standalone);
    // A failing flash: the save is retried until it succeeds.
    b.store.fail_saves.set(3);
    let mut host = Host::new();
    host.connect_and_declare(&mut shell, &mut ctl, &b.link, 40, "D&D");
    host.run(&mut shell, &mut ctl, &b.link, 46..=100);
    assert_eq!(shell.stats.store_errors, 3);
    let stored = StoredState::from_bytes(&b.store.bytes.borrow().unwrap()).unwrap();
    assert_eq!(stored, Some(StoredState::confirmed("D&D".parse().unwrap())));
}

#[test]
fn unreadable_buttons_count_as_estop() {
    let cfg = CraneConfig::default();
    let (b, _) = bench();
    let mut inputs = PinInputs {
        pressure: Adc(b.pressure.clone()),
        joystick_x: Adc(Rc::new(Cell::new(8192))),
        joystick_y: Adc(Rc::new(Cell::new(8192))),
        up: Broken,
        down: b.buttons[1].clone(),
        gripper: b.buttons[2].clone(),
        estop: b.buttons[3].clone(),
        confirm: b.buttons[4].clone(),
        show_pressure: b.buttons[5].clone(),
    };
    use firmware::hw::InputSource;
    let s = inputs.read_inputs();
    assert!(s.buttons.estop && !s.buttons.up);
    assert_eq!(s.pressure_raw, cfg.pressure_sensor.raw(0.0));
}

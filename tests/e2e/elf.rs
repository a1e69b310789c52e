//! Processor in the loop, end to end: the board's own `uno-r4` ELF in the RA4M1 emulator
//! behind a pty (hil-sim's `PtySim` with `firmware_elf`, what `hil-sim --pty --firmware-elf`
//! serves), driven by the real `host-tool` binary over `--port`. The handshake and status,
//! all 36 (initial, target) plans, a fault that must end with the actuators safe, and link
//! signing (pair, a refused and an obeyed change, unpair).

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use e2e::{binary, host_tool, parallel, STATES};
use hil_sim::pty::PtySim;
use hil_sim::{Fault, SimOptions};

/// Plans at a time: each emulator takes a core while it runs.
const THREADS: usize = 2;
const LIMIT: Duration = Duration::from_secs(120);
/// Virtual seconds per wall second. Over a pty the host keeps wall time, so a host process
/// descheduled for longer than the link watch (3 s of virtual time = 3 s / SPEED of wall time)
/// loses the link: at 5× that was 0.6 s, and the 36 plans failed with E-05 on a machine at load
/// 8–10; 2× leaves 1.5 s.
const SPEED: f64 = 2.0;

/// `cargo firmware`'s ELF (or `$UNO_R4_ELF`); panics with the command that builds it.
pub fn elf() -> PathBuf {
    let p = hil_sim::elf_board::built_elf_path();
    assert!(
        p.is_file(),
        "{} is missing: build it with `cargo firmware`",
        p.display()
    );
    p
}

fn board(initial: &str, faults: Vec<Fault>) -> PtySim {
    PtySim::spawn(SimOptions {
        initial: initial.parse().expect("a state"),
        faults,
        // Over `--port` the host keeps real time (a heartbeat every 250 ms of wall time), so
        // virtual time may run at most ~12× before the device's 3 s link watch fires; 2×
        // keeps 0.5 s of virtual time between heartbeats (the emulator may run slower: safe).
        speed: SPEED,
        firmware_elf: Some(elf()),
        ..SimOptions::default()
    })
    .expect("the emulated board starts")
}

/// `host-tool plan …` over the pty with a person at its terminal: its stdin is a terminal, and
/// when it asks for the trunk's state (the device cannot confirm a step without a calibration
/// profile: `e2e::OPERATOR_IDENTIFIED`) the person looks at the emulated trunk and types it.
/// Killed after `LIMIT`.
fn plan_as_operator(args: &[&str], sim: &PtySim) -> e2e::Output {
    as_operator(args, sim, typed_state)
}

/// What the person types when host-tool asks for the trunk's state: the state they see.
fn typed_state(line: &str, sim: &PtySim) -> Option<String> {
    line.contains("type its state").then(|| {
        sim.ground_truth()
            .true_state
            .map_or(String::new(), |s| s.to_string())
    })
}

/// `host-tool …` over the pty with a person at its terminal, who reads each line host-tool
/// writes on stderr and types `answer`'s reply to it (if any). Killed after `LIMIT`.
fn as_operator(
    args: &[&str],
    sim: &PtySim,
    mut answer: impl FnMut(&str, &PtySim) -> Option<String>,
) -> e2e::Output {
    let start = Instant::now();
    let pty = nix::pty::openpty(None, None).expect("a pty for host-tool's terminal");
    let mut keyboard = std::fs::File::from(pty.master);
    let mut child = Command::new(binary("host-tool"))
        .args(args)
        .stdin(Stdio::from(std::fs::File::from(pty.slave)))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool starts");
    let mut stdout = child.stdout.take().expect("stdout is piped");
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stdout, &mut s);
        s
    });
    let (tx, lines) = mpsc::channel();
    let err = BufReader::new(child.stderr.take().expect("stderr is piped"));
    std::thread::spawn(move || {
        for line in err.lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = start + LIMIT;
    let mut stderr = String::new();
    loop {
        match lines.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            Ok(line) => {
                if let Some(reply) = answer(&line, sim) {
                    writeln!(keyboard, "{reply}").expect("typed on host-tool's terminal");
                }
                stderr.push_str(&line);
                stderr.push('\n');
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("host-tool {args:?} did not finish within {LIMIT:?}:\n{stderr}");
            }
        }
    }
    let status = child.wait().expect("host-tool ends");
    e2e::Output {
        status,
        stdout: out.join().unwrap_or_default(),
        stderr,
        elapsed: start.elapsed(),
    }
}

#[test]
fn hil_sim_firmware_elf_serves_the_elf_and_answers_status() {
    let elf = elf();
    let sim = e2e::hil_sim_pty(&[
        std::ffi::OsStr::new("--initial"),
        "D&F".as_ref(),
        "--speed".as_ref(),
        "5".as_ref(),
        "--firmware-elf".as_ref(),
        elf.as_os_str(),
    ]);
    let (path, first) = (sim.path.clone(), sim.first_line.clone());
    let out = host_tool(
        &["status", "--port", &path, "--json"],
        Duration::from_secs(30),
    );
    drop(sim);
    assert!(first.contains("board ELF"), "{first}");
    assert_eq!(out.code(), 0, "{}", out.stderr);
    let v = out.json();
    assert_eq!(v["state"], "D&F", "{v}");
    assert_eq!(v["device"]["board"], host_board_name(), "{v}");
    assert_eq!(v["inlet_open"], false, "{v}");
}

#[test]
fn hil_sim_refuses_a_missing_firmware_elf_with_exit_1() {
    let out = e2e::run(
        &e2e::binary("hil-sim"),
        &["--pty", "--firmware-elf", "/nonexistent/uno-r4"],
        Duration::from_secs(10),
    );
    assert_eq!(out.code(), 1, "{}", out.stderr);
    assert!(out.stderr.contains("/nonexistent/uno-r4"), "{}", out.stderr);
}

/// The stack guard's limit (`board/stack.rs`: the stack pointer monitor fires 512 bytes above
/// the stack's end), and the headroom the stack must keep below it over these sessions.
const GUARD_BYTES: u32 = 512;
const HEADROOM_BYTES: u32 = 8 * 1024;

/// ICLK cycles of the 1 ms tick (48 MHz).
const TICK_CYCLES: u64 = 48_000;

/// The deepest stack of `runs` (each one session's emulated board, from the power-on) keeps
/// [`HEADROOM_BYTES`] clear of the stack guard's limit; prints it with the longest pass. And
/// the loop's timing over the pty: SCI9 overran in no session after its boot (the receive
/// handler preempts the loop, so a long pass must not cost a byte), and no session's longest stretch
/// (wake-up to `WFI`) took more than two SysTicks or ran into a third millisecond: a pass
/// that overran its tick was followed by the next one at once (passes back to back), and that
/// one ended within the same millisecond — the loop caught up and no tick's pass was skipped.
fn board_measures_hold(
    runs: impl Iterator<Item = Option<hil_sim::pty::BoardMeasures>>,
    what: &str,
) {
    let runs: Vec<_> = runs
        .map(|m| m.expect("the emulated board measured its stack"))
        .collect();
    let deepest = runs.iter().map(|m| m.stack_high_water).max().unwrap_or(0);
    let room = runs.iter().map(|m| m.stack_size).min().unwrap_or(0);
    let left = room.saturating_sub(deepest + GUARD_BYTES);
    eprintln!(
        "{what}: stack high-water {deepest} of {room} bytes ({left} to the guard's limit), \
         {} resets, {} host bytes lost ({} overruns)",
        runs.iter().map(|m| m.resets).sum::<usize>(),
        runs.iter().map(|m| m.rx_lost).sum::<u64>(),
        runs.iter().map(|m| m.rx_overruns).sum::<u64>()
    );
    // The longest loop pass of any session (after its boot), and where its cycles went.
    if let Some(m) = runs.iter().max_by_key(|m| m.longest_pass_cycles) {
        eprintln!(
            "{what}: longest loop pass {:?} cycles, SysTicks at {:?}, {} in handlers",
            m.longest_pass_cycles, m.longest_pass_ticks_at, m.longest_pass_handler_cycles
        );
        for (name, cycles) in &m.longest_pass_profile {
            eprintln!("  {cycles:>7}  {name}");
        }
        if !m.longest_pass_overrun_profile.is_empty() {
            eprintln!("{what}: of it, before the second SysTick (the pass that overran):");
            for (name, cycles) in &m.longest_pass_overrun_profile {
                eprintln!("  {cycles:>7}  {name}");
            }
        }
    }
    let overran: Vec<_> = runs
        .iter()
        .filter_map(|m| m.last_overrun_ms.map(|t| (m.rx_overruns, t)))
        .collect();
    eprintln!("{what}: SCI9 overruns (count, the last at ms): {overran:?}");
    for m in &runs {
        // The host's first bytes come while the board boots (its interrupts still off while
        // the shell reads the flash log, ≈ 3 ms): those overrun and the handshake is retried.
        // After the boot, in the loop, none may.
        assert!(
            m.last_overrun_ms.is_none_or(|t| t < hil_sim::pty::BOOT_MS),
            "{what}: SCI9 overran after the boot: {m:?}"
        );
        assert!(
            m.longest_pass_ticks_at.len() <= 2
                && m.longest_pass_cycles.unwrap_or(0) < 2 * TICK_CYCLES,
            "{what}: a stretch ran past the next millisecond: {m:?}"
        );
    }
    assert!(
        deepest + GUARD_BYTES + HEADROOM_BYTES <= room,
        "{what}: stack {deepest} of {room} bytes leaves {left} to the guard, under {HEADROOM_BYTES}"
    );
}

fn host_board_name() -> &'static str {
    "Arduino UNO R4 WiFi"
}

#[test]
fn all_36_plans_reach_their_target_on_the_elf() {
    let pairs: Vec<(&str, &str)> = STATES
        .iter()
        .flat_map(|a| STATES.iter().map(move |b| (*a, *b)))
        .collect();
    let start = Instant::now();
    let results = parallel(pairs, THREADS, |(from, to)| {
        let sim = board(from, vec![]);
        let path = sim.path().display().to_string();
        let out = plan_as_operator(&["plan", "--target", to, "--port", &path, "--json"], &sim);
        let (truth, board) = sim.stop_measured();
        (from, to, out, truth, board)
    });
    eprintln!(
        "36 plans on the emulated ELF ({THREADS} at a time): {:.1?}",
        start.elapsed()
    );
    board_measures_hold(results.iter().map(|r| r.4.clone()), "the 36 plans");
    let mut failures = Vec::new();
    let mut retried = 0;
    for (from, to, out, truth, _) in &results {
        let v = out.json();
        let ok = out.code() == 0
            && v["ok"] == true
            && v["final_state"] == *to
            && truth.true_state == Some(to.parse().unwrap())
            && truth.actuators_safe
            && truth.max_pressure_kpa <= truth.pressure_limit_kpa + 0.5;
        if ok {
            continue;
        }
        // Seen on a machine at load ≈ 10 (the host keeps wall time over the pty): a manual
        // step's check ending E-04, unconfirmed. Such a failure must still be honest and safe
        // (never a confirmed false state), the same plan must then succeed, and only one plan
        // of the 36 may need it.
        let honest = v["state_confirmed"] != true
            || truth.true_state.map(|s| s.to_string())
                == v["final_state"].as_str().map(String::from);
        let first = format!("{from} → {to}: exit {} {v} truth {truth:?}", out.code());
        assert!(
            honest && truth.actuators_safe,
            "dishonest or unsafe failure: {first}"
        );
        eprintln!("retrying after an honest failure: {first}");
        retried += 1;
        if retried > 1 {
            failures.push(format!("{first}\n  (a second plan needing a retry)"));
            continue;
        }
        let sim = board(from, vec![]);
        let path = sim.path().display().to_string();
        let again = plan_as_operator(&["plan", "--target", to, "--port", &path, "--json"], &sim);
        let truth2 = sim.stop();
        let v2 = again.json();
        if !(again.code() == 0
            && v2["ok"] == true
            && v2["final_state"] == *to
            && truth2.true_state == Some(to.parse().unwrap())
            && truth2.actuators_safe)
        {
            failures.push(format!("{first}\n  and again: exit {} {v2}", again.code()));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of 36 failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_fault_subset_fails_cleanly_on_the_elf_with_the_actuators_safe() {
    // The cases of `faults.rs` (the host-built controller's), on the board ELF: each ends in
    // exit 1 naming the failed step and the diagnosis, with the inlet closed, the pressure
    // within its cap and the servos limp or at their command.
    let cases = vec![
        (
            Fault::ValveStuckClosed,
            "F&P",
            "D&F",
            "step 1/2 (pneumatic F&P → F&F) failed",
            "(E-12)",
        ),
        (
            Fault::Leak,
            "F&P",
            "D&F",
            "step 1/2 (pneumatic F&P → F&F) failed",
            "(E-08)",
        ),
        (
            Fault::ServoStall,
            "D&D",
            "F&D",
            "step 1/1 (tendon D&D → F&D) failed",
            "(E-04)",
        ),
        (
            Fault::LinkDrop,
            "F&P",
            "D&D",
            "link lost during step 1/3 (pneumatic F&P → F&F)",
            "the device aborts to its safe state by itself",
        ),
    ];
    let results = parallel(cases, THREADS, |(fault, from, to, step, why)| {
        let sim = board(from, vec![fault]);
        let path = sim.path().display().to_string();
        let out = plan_as_operator(&["plan", "--target", to, "--port", &path, "--json"], &sim);
        // Judge the actuators once the device's own link watch has had its whole time, on the
        // device's clock, since the host went away: a dropped link is for the device to act on.
        let gone_ms = sim.ground_truth().time_ms;
        let watch_ms = u64::from(sim.link_timeout_ms());
        assert!(
            sim.ground_truth_at(gone_ms + watch_ms + 200, LIMIT)
                .is_some(),
            "{fault:?}: the emulated board stopped"
        );
        let (truth, board) = sim.stop_measured();
        (fault, step, why, out, truth, board)
    });
    board_measures_hold(results.iter().map(|r| r.5.clone()), "the fault subset");
    for (fault, step, why, out, truth, _) in results {
        let v = out.json();
        assert_eq!(out.code(), 1, "{fault:?}: {v}\n{}", out.stderr);
        assert_eq!(v["ok"], false, "{fault:?}: {v}");
        let error = v["error"].as_str().unwrap_or_default();
        assert!(error.contains(step), "{fault:?}: {error}");
        assert!(error.contains(why), "{fault:?}: {error}");
        assert!(truth.actuators_safe, "{fault:?}: {truth:?}");
        assert!(!truth.inlet_open, "{fault:?}: {truth:?}");
        assert!(
            truth.max_pressure_kpa <= truth.pressure_limit_kpa,
            "{fault:?}: {truth:?}"
        );
    }
}

/// The point `(X, Y, Z)` in `line` right after `prefix`, mm.
fn point_after(line: &str, prefix: &str) -> Option<[f64; 3]> {
    let rest = &line[line.find(prefix)? + prefix.len()..];
    let nums: Vec<f64> = rest[..rest.find(')')?]
        .split(',')
        .map(|v| v.trim().parse().ok())
        .collect::<Option<_>>()?;
    nums.try_into().ok()
}

/// §6.3 on the board's ELF (processor in the loop), as with a real crane: `demo manipulation
/// --port` asks the person to place each object; the person puts it into the simulator's world
/// at the point asked and presses Enter, and types the trunk's state when asked (no
/// calibration profile on the device). All three objects are carried and end on the table,
/// not held, below the points the demo carried them to within [`UNCALIBRATED_PLACE_MM`].
/// How far from below its place point an object may land over a port, mm. The demo's 5 mm is
/// for a bend model calibrated against the trunk (`--sim` calibrates it against the
/// simulator's: 0.4–0.5 mm); over a port nothing has calibrated it, and the model's tip is off
/// the simulated trunk's by 3.7–5.4 mm in these three carries (measured 2026-12-04, three runs).
const UNCALIBRATED_PLACE_MM: f64 = 6.0;

#[test]
fn the_manipulation_demo_places_every_object_on_the_elf() {
    let sim = board("F&P", vec![]);
    let path = sim.path().display().to_string();
    let mut asked = Vec::new();
    let mut carried = Vec::new();
    let out = as_operator(
        &["demo", "manipulation", "--port", &path],
        &sim,
        |line, sim| {
            if let Some(at) = point_after(line, "grasp point at (") {
                let object = hil_sim::world::Object {
                    name: format!("object{}", asked.len()),
                    position_mm: at,
                    mass_kg: 0.05,
                    held: false,
                };
                sim.place_object(object, Duration::from_secs(10))
                    .expect("placed in the world");
                asked.push(at);
                return Some(String::new());
            }
            if let Some(to) = point_after(line, "carry to (") {
                carried.push(to);
            }
            typed_state(line, sim)
        },
    );
    let objects = sim.objects();
    let truth = sim.stop();
    assert_eq!(out.code(), 0, "{}\n{}", out.stdout, out.stderr);
    assert_eq!((asked.len(), carried.len()), (3, 3), "{}", out.stderr);
    assert!(
        out.stderr.contains("places are not checked"),
        "over a port the demo says it cannot check the places: {}",
        out.stderr
    );
    assert!(truth.actuators_safe, "{truth:?}");
    for (i, to) in carried.iter().enumerate() {
        let o = objects
            .iter()
            .find(|o| o.name == format!("object{i}"))
            .expect("the object is in the world");
        let d = (o.position_mm[0] - to[0]).hypot(o.position_mm[1] - to[1]);
        let moved = (o.position_mm[0] - asked[i][0]).hypot(o.position_mm[1] - asked[i][1]);
        eprintln!("object {i}: {d:.1} mm from below {to:?}, carried {moved:.1} mm");
        assert!(
            !o.held && o.position_mm[2] == 0.0 && d <= UNCALIBRATED_PLACE_MM && moved > 5.0,
            "object {i} at {:?}, {d:.1} mm from below {to:?} (held: {})\n{}",
            o.position_mm,
            o.held,
            out.stderr
        );
    }
}

/// One calibration on the board ELF through the binaries: `host-tool calibrate --manual` over
/// the pty, with a person who makes and undoes the half-packed rests when asked and types the
/// trunk's state where the device cannot tell it. The probe's signatures it measured are stored
/// in the board's data flash: `calibration show` reads back the same rates, and again after a
/// power cut (`hil-sim/tests/elf.rs` checks that identification decides from a stored
/// profile).
#[test]
fn one_calibration_on_the_elf_stores_its_probe_profile_across_a_power_cycle() {
    use hil_sim::physics::trunk::Module;
    let sim = board("F&P", vec![]);
    let path = sim.path().display().to_string();
    let dir = std::env::temp_dir().join(format!("e2e-elf-calibrate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("crane.toml");
    let folds = [
        ("please fold the bottom module's lowest unit", 1),
        ("please unfold that unit again", 2),
        ("please unfold the bottom module's upper unit", 1),
        ("please fold that unit back into self-packing", 0),
    ];
    let mut made = Vec::new();
    let out = as_operator(
        &[
            "calibrate",
            "--port",
            &path,
            "--manual",
            "--out",
            profile.to_str().unwrap(),
            "-j",
        ],
        &sim,
        |line, sim| {
            if let Some(&(_, well)) = folds.iter().find(|(ask, _)| line.contains(ask)) {
                sim.move_module_by_hand(Module::Bottom, well, Duration::from_secs(10));
                made.push(well);
                return Some(String::new());
            }
            typed_state(line, sim)
        },
    );
    assert_eq!(out.code(), 0, "{}\n{}", out.stdout, out.stderr);
    assert_eq!(made, [1, 2, 1, 0], "{}", out.stderr);
    let v = out.json();
    assert_eq!(v["stored_on_device"], true, "{v}");
    let rates = |v: &serde_json::Value| -> Vec<f64> {
        ["states", "between"]
            .iter()
            .flat_map(|k| v[k].as_array().cloned().unwrap_or_default())
            .map(|r| r.as_f64().expect("a rate"))
            .collect()
    };
    let measured = rates(&v["probe"]);
    assert_eq!(measured.len(), 8, "{v}");
    eprintln!(
        "calibration on the ELF: {:.1} s, probe {:?}",
        v["duration_s"], v["probe"]
    );
    let show = || {
        let shown = host_tool(
            &["calibration", "show", "--port", &path, "-j"],
            Duration::from_secs(60),
        );
        assert_eq!(shown.code(), 0, "{}", shown.stderr);
        let stored = rates(&shown.json()["device_profile"]);
        if stored.len() != 8 {
            let st = host_tool(&["status", "--port", &path, "-j"], Duration::from_secs(60));
            eprintln!("no profile read back; the device's status: {}", st.stdout);
        }
        assert_eq!(stored.len(), 8, "{} {}", shown.stdout, shown.stderr);
        for (a, b) in measured.iter().zip(&stored) {
            // The file holds two decimals, the device the f32 of the same number.
            assert!((a - b).abs() < 1e-3, "{measured:?} vs {stored:?}");
        }
    };
    // Read back (the device writes its flash in the background, ≈ 25 ms after its answer: a
    // cut in that window boots with no profile, docs/firmware.md), then across a power cut.
    show();
    sim.power_cycle(Duration::from_secs(10));
    show();
    let truth = sim.stop();
    assert!(truth.actuators_safe, "{truth:?}");
    assert_eq!(truth.true_state.map(|s| s.to_string()), Some("F&P".into()));
}

/// Link signing on the board ELF through the binaries: `host-tool signing pair` gives the
/// emulated board a key (kept in its data flash), the handshake then says it signs, a
/// parameter change without the key is refused and with it obeyed, and `signing off` turns it
/// off again.
#[test]
fn host_tool_pairs_the_elf_obeys_only_signed_changes_and_unpairs() {
    let sim = board("F&F", vec![]);
    let path = sim.path().display().to_string();
    let dir = std::env::temp_dir().join(format!("e2e-elf-signing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let key_file = dir.join("crane.key");
    let _ = std::fs::remove_file(&key_file);
    let kf = key_file.to_str().unwrap();
    let limit = Duration::from_secs(60);
    let signs = || {
        let out = host_tool(&["signing", "show", "--port", &path, "--json"], limit);
        assert_eq!(out.code(), 0, "{}", out.stderr);
        out.json()["signing"].as_bool().expect("a flag")
    };
    assert!(!signs(), "a fresh board does not sign");
    let pair = host_tool(
        &[
            "signing",
            "pair",
            "--port",
            &path,
            "--key-file",
            kf,
            "--json",
        ],
        limit,
    );
    assert_eq!(pair.code(), 0, "{}", pair.stderr);
    assert!(signs(), "the handshake says the board signs");
    let set = |value: &str, key: Option<&str>| {
        let mut args = vec!["param", "set", "pressure-limit-kpa", value, "--port", &path];
        if let Some(k) = key {
            args.extend_from_slice(&["--link-key", k]);
        }
        host_tool(&args, limit)
    };
    let refused = set("30", None);
    assert_eq!(refused.code(), 1, "{}", refused.stderr);
    assert!(
        refused.stderr.contains("not validly signed"),
        "{}",
        refused.stderr
    );
    let obeyed = set("31", Some(kf));
    assert_eq!(obeyed.code(), 0, "{}", obeyed.stderr);
    let get = host_tool(
        &[
            "param",
            "get",
            "pressure-limit-kpa",
            "--port",
            &path,
            "--link-key",
            kf,
            "--json",
        ],
        limit,
    );
    assert_eq!(get.code(), 0, "{}", get.stderr);
    assert_eq!(get.json()["params"][0]["value"].as_f64(), Some(31.0));
    let off = host_tool(
        &["signing", "off", "--port", &path, "--link-key", kf],
        limit,
    );
    assert_eq!(off.code(), 0, "{}", off.stderr);
    assert!(!signs(), "unpaired");
    assert_eq!(set("40", None).code(), 0, "plain changes obeyed again");
    drop(sim);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `calibrate --port P --trunk FILE`: on a real crane the trunk's description names the
/// profile (and is checked first). Over the pty of the simulated crane (the host-built
/// controller, the description's trunk) with the person at host-tool's terminal typing the
/// states the device cannot vouch for without a probe profile.
#[test]
fn calibrate_over_a_port_names_the_profile_from_the_trunks_description() {
    let dir = std::env::temp_dir().join(format!("e2e-port-trunk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let trunk = dir.join("my-print.toml");
    let pdf = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../trunks/pdf.toml"))
        .unwrap();
    assert!(pdf.contains("\nname = \"pdf\"\n"));
    std::fs::write(
        &trunk,
        pdf.replace("\nname = \"pdf\"\n", "\nname = \"my-print\"\n"),
    )
    .unwrap();
    let trunk_s = trunk.to_str().unwrap();
    let sim = PtySim::spawn(SimOptions {
        initial: "F&P".parse().unwrap(),
        speed: 5.0,
        trunk: hil_sim::physics::TrunkSpec::load(&trunk).unwrap(),
        ..SimOptions::default()
    })
    .expect("the simulated crane starts");
    let path = sim.path().display().to_string();
    let profile = dir.join("profile.toml");
    let profile_s = profile.to_str().unwrap();
    let out = plan_as_operator(
        &[
            "calibrate",
            "--port",
            &path,
            "--trunk",
            trunk_s,
            "--out",
            profile_s,
            "-j",
        ],
        &sim,
    );
    assert_eq!(out.code(), 0, "{}\n{}", out.stdout, out.stderr);
    assert_eq!(out.json()["name"], "my-print");
    let text = std::fs::read_to_string(&profile).unwrap();
    assert!(text.contains("name = \"my-print\""), "{text}");
    // A description that is not one is refused before the port is opened (exit 2).
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, pdf.replace("[pneumatics]", "[pneumatic]")).unwrap();
    let out = host_tool(
        &[
            "calibrate",
            "--port",
            &path,
            "--trunk",
            bad.to_str().unwrap(),
            "--out",
            profile_s,
        ],
        Duration::from_secs(60),
    );
    assert_eq!(out.code(), 2, "{}", out.stderr);
    assert!(
        out.stderr
            .contains(&format!("invalid trunk {}", bad.display())),
        "{}",
        out.stderr
    );
}

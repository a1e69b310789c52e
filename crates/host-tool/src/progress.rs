//! Showing a run to people: a progress bar per step on a terminal, plain lines otherwise.
//! Everything goes to stderr, so `--json` output on stdout stays machine-readable.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use planner::graph::{kind_name, manual_task_text, Plan};
use protocol::ManualTask;

use host::StepReport;

/// Where a run shows its progress (a terminal, plain lines, nothing).
pub trait Progress {
    /// A plan was made (`replan`: after a surprise).
    fn plan(&mut self, plan: &Plan, replan: bool);
    /// Step `index` of `total` started.
    fn step_started(&mut self, index: usize, total: usize, plan: &Plan);
    /// Step `index` is running: `elapsed_ms` of device time, latest pressure.
    fn step_progress(&mut self, index: usize, elapsed_ms: u32, pressure_kpa: f32);
    /// A manual step waits for a person; `enter_confirms`: Enter on stdin works too.
    fn manual_prompt(&mut self, index: usize, task: ManualTask, enter_confirms: bool);
    /// Step `index` ended.
    /// A step ended; `aborted`: it ended because this host cancelled the run (an operator's
    /// stop, a signal, a time limit), not by a failure of its own.
    fn step_finished(&mut self, index: usize, report: &StepReport, aborted: bool);
    /// Anything else worth a line.
    fn note(&mut self, message: &str);
}

/// Plain lines on stderr (pipes, logs, CI).
pub struct Lines;

fn step_line(plan: &Plan, index: usize) -> String {
    let total = plan.steps().len();
    let s = &plan.steps()[index];
    format!(
        "step {}/{} {} {} → {}",
        index + 1,
        total,
        kind_name(s.edge.kind()),
        s.edge.from(),
        s.edge.to()
    )
}

/// The line of a step that ended: `step 2 pneumatic F&P → F&F: done in 5.2 s` (`FAILED`, or
/// `aborted` when the host cancelled the run).
pub fn finished_line(index: usize, r: &StepReport, aborted: bool) -> String {
    let took = r.duration_ms.map_or(String::new(), |ms| {
        format!(" in {:.1} s", f64::from(ms) / 1000.0)
    });
    format!(
        "step {} {} {} → {}: {}{took}",
        index + 1,
        kind_name(r.kind),
        r.from,
        r.to,
        match (r.ok, aborted) {
            (true, _) => "done",
            (false, true) => "aborted",
            (false, false) => "FAILED",
        }
    )
}

fn manual_line(task: ManualTask, enter: bool) -> String {
    format!(
        "MANUAL STEP: {}; then press the confirm button on the crane{}",
        manual_task_text(task),
        if enter { " or Enter here" } else { "" }
    )
}

impl Progress for Lines {
    fn plan(&mut self, plan: &Plan, replan: bool) {
        if replan {
            crate::say!("new plan:");
        }
        crate::say_raw!("{}", crate::cli::wrap(&plan.to_string()));
    }

    fn step_started(&mut self, index: usize, _total: usize, plan: &Plan) {
        crate::say!("{} …", step_line(plan, index));
    }

    fn step_progress(&mut self, _: usize, _: u32, _: f32) {}

    fn manual_prompt(&mut self, _index: usize, task: ManualTask, enter_confirms: bool) {
        crate::say!("{}", manual_line(task, enter_confirms));
    }

    fn step_finished(&mut self, index: usize, report: &StepReport, aborted: bool) {
        crate::say!("{}", finished_line(index, report, aborted));
    }

    fn note(&mut self, message: &str) {
        crate::say!("{message}");
    }
}

/// One progress bar per step on a terminal; its length is the step's expected duration and
/// its position the device time elapsed.
#[derive(Default)]
pub struct Bars {
    bar: Option<ProgressBar>,
}

impl Bars {
    fn done(&mut self) -> Option<ProgressBar> {
        self.bar.take()
    }
}

impl Progress for Bars {
    fn plan(&mut self, plan: &Plan, replan: bool) {
        if replan {
            crate::say!("new plan:");
        }
        crate::say_raw!("{}", crate::cli::wrap(&plan.to_string()));
    }

    fn step_started(&mut self, index: usize, _total: usize, plan: &Plan) {
        if let Some(old) = self.done() {
            old.finish_and_clear();
        }
        let expected_ms = (plan.steps()[index].edge.cost_s * 1000.0).max(1.0) as u64;
        let bar = ProgressBar::with_draw_target(
            Some(expected_ms),
            ProgressDrawTarget::term_like_with_hz(Box::new(Stderr(console::Term::stderr())), 20),
        );
        // `wide_bar` takes what the terminal's width leaves: the line never wraps.
        let style = ProgressStyle::with_template("{prefix:.bold} [{wide_bar:.cyan/blue}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        bar.set_style(style);
        bar.set_prefix(step_line(plan, index));
        bar.enable_steady_tick(Duration::from_millis(120));
        self.bar = Some(bar);
    }

    fn step_progress(&mut self, _: usize, elapsed_ms: u32, pressure_kpa: f32) {
        if let Some(bar) = &self.bar {
            bar.set_position(u64::from(elapsed_ms).min(bar.length().unwrap_or(0)));
            bar.set_message(format!(
                "{:.1} s  {pressure_kpa:5.1} kPa",
                f64::from(elapsed_ms) / 1000.0
            ));
        }
    }

    fn manual_prompt(&mut self, _index: usize, task: ManualTask, enter_confirms: bool) {
        let line = crate::cli::wrap(&manual_line(task, enter_confirms));
        match &self.bar {
            Some(bar) => bar.println(line),
            None => crate::say!("{line}"),
        }
    }

    fn step_finished(&mut self, index: usize, report: &StepReport, aborted: bool) {
        let line = finished_line(index, report, aborted);
        match self.done() {
            Some(bar) => {
                bar.finish_and_clear();
                crate::say!("{line}");
            }
            None => crate::say!("{line}"),
        }
    }

    fn note(&mut self, message: &str) {
        match &self.bar {
            Some(bar) => bar.println(crate::cli::wrap(message)),
            None => crate::say!("{message}"),
        }
    }
}

/// The terminal the bars draw on: stderr, as wide as [`crate::cli::width`] says (`COLUMNS`
/// when set, as for every other line), so a bar is never wider than the text around it.
#[derive(Debug)]
struct Stderr(console::Term);

impl TermLike for Stderr {
    fn width(&self) -> u16 {
        crate::cli::width().map_or(self.0.size().1, |w| w.min(usize::from(u16::MAX)) as u16)
    }
    fn height(&self) -> u16 {
        self.0.size().0
    }
    fn move_cursor_up(&self, n: usize) -> std::io::Result<()> {
        self.0.move_cursor_up(n)
    }
    fn move_cursor_down(&self, n: usize) -> std::io::Result<()> {
        self.0.move_cursor_down(n)
    }
    fn move_cursor_right(&self, n: usize) -> std::io::Result<()> {
        self.0.move_cursor_right(n)
    }
    fn move_cursor_left(&self, n: usize) -> std::io::Result<()> {
        self.0.move_cursor_left(n)
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.0.write_line(s)
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.0.write_str(s)
    }
    fn clear_line(&self) -> std::io::Result<()> {
        self.0.clear_line()
    }
    fn flush(&self) -> std::io::Result<()> {
        self.0.flush()
    }
}

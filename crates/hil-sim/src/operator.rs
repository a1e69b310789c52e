//! The simulated person at the crane: does the manual step the crane asks for.
//!
//! They watch the display; when it names a manual task (`H-Pb`, `H-Ft`, `H-Fb`: a manual step
//! waits, [`firmware::display::task`]) they walk over, do that task, and press the confirm
//! button. Reaction and work take [`OPERATOR_DELAY_MS`]. They read only what a person at the
//! crane can read: the display, never the link.

use protocol::messages::ManualTask;

/// The manual task the display's segments name, if any (decimal points aside).
pub fn task_shown(segments: [u8; 4]) -> Option<ManualTask> {
    let seg = segments.map(|d| d & !firmware::display::DP);
    [
        ManualTask::PackBottomModule,
        ManualTask::FoldTopModule,
        ManualTask::FoldBottomModule,
    ]
    .into_iter()
    .find(|t| firmware::display::task(*t) == seg)
}

/// From the task appearing to the confirm press: walking over and folding two layers of panels.
pub const OPERATOR_DELAY_MS: u64 = 5_000;
/// The fold itself, the last part of [`OPERATOR_DELAY_MS`]: hands move the panels over this
/// long (the trunk's air leaves through the open exhaust meanwhile), then confirm.
pub const FOLD_MS: u64 = 3_000;
/// How long the confirm button is held.
pub const CONFIRM_PRESS_MS: u64 = 200;

/// What the operator does in a millisecond.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OperatorAction {
    /// Nothing.
    None,
    /// Begin folding the panels of this task by hand, to be done `over_ms` from now (when
    /// the confirm press comes).
    Fold {
        /// The task.
        task: ManualTask,
        /// How long the fold takes, ms.
        over_ms: u64,
    },
}

/// A mistake the operator will make at the next manual step (the swarm tester's scripts).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mistake {
    /// Folds this instead of what was asked, and confirms.
    WrongFold(ManualTask),
    /// Does not come: nothing is folded and nothing confirmed.
    Refuse,
}

/// The operator's state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Operator {
    /// Whether the operator is there at all.
    pub enabled: bool,
    due_ms: Option<u64>,
    /// The fold of the task due began (its hands are on the panels).
    folding: bool,
    release_ms: Option<u64>,
    /// Manual tasks done so far.
    pub tasks_done: u32,
    /// The mistake to make at the next manual step, if any.
    pub mistake: Option<Mistake>,
}

impl Operator {
    /// An operator, present or not.
    pub fn new(enabled: bool) -> Self {
        Self {
            enabled,
            due_ms: None,
            folding: false,
            release_ms: None,
            tasks_done: 0,
            mistake: None,
        }
    }

    /// One millisecond: sees which task the display asks for (`shown`), acts when due.
    /// Returns the action and whether the confirm button is held now.
    pub fn tick(&mut self, now_ms: u64, shown: Option<ManualTask>) -> (OperatorAction, bool) {
        if !self.enabled {
            return (OperatorAction::None, false);
        }
        let mut action = OperatorAction::None;
        if let Some(r) = self.release_ms {
            if now_ms >= r {
                self.release_ms = None;
            }
            return (action, self.release_ms.is_some());
        }
        match (shown, self.due_ms) {
            (Some(_), None) => self.due_ms = Some(now_ms + OPERATOR_DELAY_MS),
            (None, Some(_)) => {
                // The prompt went away: the person stops there (a fold begun is finished: its
                // panels are not left halfway), and confirms nothing.
                self.due_ms = None;
                self.folding = false;
            }
            (Some(asked), Some(due)) => {
                if !self.folding && now_ms.saturating_add(FOLD_MS) >= due {
                    let task = match self.mistake {
                        Some(Mistake::Refuse) => {
                            // Stays away; the step's time limit ends the wait.
                            self.mistake = None;
                            self.due_ms = Some(u64::MAX);
                            return (action, false);
                        }
                        Some(Mistake::WrongFold(t)) => {
                            self.mistake = None;
                            t
                        }
                        None => asked,
                    };
                    action = OperatorAction::Fold {
                        task,
                        over_ms: due.saturating_sub(now_ms),
                    };
                    self.tasks_done += 1;
                    self.folding = true;
                }
                if now_ms >= due {
                    self.due_ms = None;
                    self.folding = false;
                    self.release_ms = Some(now_ms + CONFIRM_PRESS_MS);
                }
            }
            _ => {}
        }
        (action, self.release_ms.is_some())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOP: Option<ManualTask> = Some(ManualTask::FoldTopModule);

    #[test]
    fn acts_after_the_delay_and_holds_confirm() {
        let mut o = Operator::new(true);
        assert_eq!(o.tick(0, TOP), (OperatorAction::None, false));
        let begin = OPERATOR_DELAY_MS - FOLD_MS;
        assert_eq!(o.tick(begin - 1, TOP), (OperatorAction::None, false));
        assert_eq!(
            o.tick(begin, TOP),
            (
                OperatorAction::Fold {
                    task: ManualTask::FoldTopModule,
                    over_ms: FOLD_MS
                },
                false
            )
        );
        assert_eq!(o.tasks_done, 1);
        // Folding: no second fold, no confirm before the fold is done.
        assert_eq!(
            o.tick(OPERATOR_DELAY_MS - 1, TOP),
            (OperatorAction::None, false)
        );
        assert_eq!(o.tick(OPERATOR_DELAY_MS, TOP), (OperatorAction::None, true));
        assert!(o.tick(OPERATOR_DELAY_MS + 100, TOP).1);
        assert!(!o.tick(OPERATOR_DELAY_MS + CONFIRM_PRESS_MS, TOP).1);
        assert_eq!(o.tasks_done, 1);
    }

    #[test]
    fn reads_each_task_from_the_display_and_nothing_else() {
        for t in [
            ManualTask::PackBottomModule,
            ManualTask::FoldTopModule,
            ManualTask::FoldBottomModule,
        ] {
            let mut seg = firmware::display::task(t);
            assert_eq!(task_shown(seg), Some(t));
            seg[3] |= firmware::display::DP;
            assert_eq!(task_shown(seg), Some(t));
        }
        assert_eq!(task_shown(firmware::display::text("d-F ")), None);
        assert_eq!(task_shown(firmware::display::text("HAnd")), None);
    }

    #[test]
    fn an_absent_operator_does_nothing() {
        let mut o = Operator::new(false);
        for t in 0..20_000 {
            assert_eq!(o.tick(t, TOP), (OperatorAction::None, false));
        }
    }

    #[test]
    fn a_prompt_that_goes_away_is_not_acted_on() {
        let mut o = Operator::new(true);
        o.tick(0, TOP);
        o.tick(10, None);
        assert_eq!(o.tick(OPERATOR_DELAY_MS + 1, TOP).0, OperatorAction::None);
    }

    #[test]
    fn a_prompt_that_goes_away_mid_fold_is_not_confirmed() {
        let mut o = Operator::new(true);
        o.tick(0, TOP);
        assert!(matches!(
            o.tick(OPERATOR_DELAY_MS - FOLD_MS, TOP).0,
            OperatorAction::Fold { .. }
        ));
        assert_eq!(
            o.tick(OPERATOR_DELAY_MS - 10, None),
            (OperatorAction::None, false)
        );
        assert_eq!(
            o.tick(OPERATOR_DELAY_MS, None),
            (OperatorAction::None, false)
        );
        assert_eq!(o.tasks_done, 1);
    }
}

//! The simulated person at the crane: does the manual step the crane asks for.
//!
//! They watch the display; when it shows `HAnd` (a manual step waits) they walk over, do the
//! task the host's prompt named (the `ManualRequired` event on the link; packing the bottom if
//! none was seen), and press the confirm button. Reaction and work take [`OPERATOR_DELAY_MS`].

use protocol::messages::ManualTask;

/// From `HAnd` appearing to the confirm press: walking over and folding two layers of panels.
pub const OPERATOR_DELAY_MS: u64 = 5_000;
/// How long the confirm button is held.
pub const CONFIRM_PRESS_MS: u64 = 200;

/// What the operator does in a millisecond.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OperatorAction {
    /// Nothing.
    None,
    /// Fold the panels of this task by hand now.
    DoTask(ManualTask),
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
    /// The task named by the last `ManualRequired` event seen.
    pub prompted_task: Option<ManualTask>,
    due_ms: Option<u64>,
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
            prompted_task: None,
            due_ms: None,
            release_ms: None,
            tasks_done: 0,
            mistake: None,
        }
    }

    /// One millisecond: sees whether the display asks for a hand (`wants_hand`), acts when due.
    /// Returns the action and whether the confirm button is held now.
    pub fn tick(&mut self, now_ms: u64, wants_hand: bool) -> (OperatorAction, bool) {
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
        match (wants_hand, self.due_ms) {
            (true, None) => self.due_ms = Some(now_ms + OPERATOR_DELAY_MS),
            (false, Some(_)) => self.due_ms = None,
            (true, Some(due)) if now_ms >= due => {
                let asked = self
                    .prompted_task
                    .take()
                    .unwrap_or(ManualTask::PackBottomModule);
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
                action = OperatorAction::DoTask(task);
                self.tasks_done += 1;
                self.due_ms = None;
                self.release_ms = Some(now_ms + CONFIRM_PRESS_MS);
            }
            _ => {}
        }
        (action, self.release_ms.is_some())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acts_after_the_delay_and_holds_confirm() {
        let mut o = Operator::new(true);
        o.prompted_task = Some(ManualTask::FoldTopModule);
        assert_eq!(o.tick(0, true), (OperatorAction::None, false));
        assert_eq!(
            o.tick(OPERATOR_DELAY_MS - 1, true),
            (OperatorAction::None, false)
        );
        assert_eq!(
            o.tick(OPERATOR_DELAY_MS, true),
            (OperatorAction::DoTask(ManualTask::FoldTopModule), true)
        );
        assert!(o.tick(OPERATOR_DELAY_MS + 100, true).1);
        assert!(!o.tick(OPERATOR_DELAY_MS + CONFIRM_PRESS_MS, true).1);
        assert_eq!(o.tasks_done, 1);
    }

    #[test]
    fn an_absent_operator_does_nothing() {
        let mut o = Operator::new(false);
        for t in 0..20_000 {
            assert_eq!(o.tick(t, true), (OperatorAction::None, false));
        }
    }

    #[test]
    fn a_prompt_that_goes_away_is_not_acted_on() {
        let mut o = Operator::new(true);
        o.tick(0, true);
        o.tick(10, false);
        assert_eq!(o.tick(OPERATOR_DELAY_MS + 1, true).0, OperatorAction::None);
    }
}

//! `plan --json`'s outcome document, typed: `plan` prints it, `serve` sends it to its clients
//! ([`crate::serve_protocol::Reply::Outcome`]) and records it on `/run`; `plan`, `identify` and
//! `reach` through a server read it back.

use geometry::TrunkState;
use host::{text, Outcome};
use planner::graph::kind_name;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::sim::SimTruth;

/// The `plan --json` object: `ok, from, target, final_state, state_confirmed, candidates,
/// identified, steps, error, fault_code, failure (kind, step, fault_code, fault, reject,
/// refused, message), sim`. `final_state` is the last state the device reported;
/// `state_confirmed` says whether the device had confirmed it then — after a lost link it is
/// `false`: the report is stale, and `candidates` (present when unconfirmed) is every state the
/// trunk may be in since (all six: unknown).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct PlanOutcome {
    /// The run reached its target.
    pub ok: bool,
    /// The state it started from.
    pub from: Option<String>,
    /// The state it was to reach.
    pub target: Option<String>,
    /// The last state the device reported.
    pub final_state: Option<String>,
    /// Whether the device had confirmed it.
    pub state_confirmed: bool,
    /// Every state the trunk may be in, when unconfirmed.
    pub candidates: Option<Vec<String>>,
    /// The run identified the state.
    pub identified: bool,
    /// The steps run.
    pub steps: Vec<StepOutcome>,
    /// Why it failed.
    pub error: Option<String>,
    /// The device fault that failed it, by code.
    pub fault_code: Option<String>,
    /// How it failed.
    pub failure: Option<FailureOutcome>,
    /// The simulator's ground truth after the run.
    pub sim: Option<SimTruth>,
}

/// One step of the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StepOutcome {
    /// How it is actuated.
    pub kind: String,
    /// Its start state.
    pub from: String,
    /// The state it was to reach.
    pub to: String,
    /// It completed.
    pub ok: bool,
    /// How long it took, where known.
    pub duration_ms: Option<u32>,
}

/// A failed run's typed failure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FailureOutcome {
    /// What failed (`host::FailureKind`'s name).
    pub kind: String,
    /// The step it failed in.
    pub step: Option<FailedStep>,
    /// The device fault, by code.
    pub fault_code: Option<String>,
    /// The device fault, by name.
    pub fault: Option<String>,
    /// The device's rejection reason.
    pub reject: Option<String>,
    /// The device's refusal of a plan.
    pub refused: Option<crate::cli::Refused>,
    /// The message.
    pub message: String,
}

/// Where a run failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FailedStep {
    /// The step's index (0-based).
    pub index: usize,
    /// Steps in the plan.
    pub total: usize,
    /// How it is actuated.
    pub kind: String,
    /// Its start state.
    pub from: String,
    /// The state it was to reach.
    pub to: String,
}

impl PlanOutcome {
    /// The document of a run's outcome (with the simulator's truth, if any).
    pub fn of(out: &Outcome, truth: Option<&SimTruth>) -> Self {
        let name = |s: Option<TrunkState>| s.map(|s| s.name().to_string());
        Self {
            ok: out.ok(),
            from: name(out.from),
            target: name(out.target),
            final_state: name(out.final_state),
            state_confirmed: out.state_confirmed,
            candidates: (!out.state_confirmed).then(|| {
                out.candidates
                    .iter()
                    .map(|c| c.name().to_string())
                    .collect()
            }),
            identified: out.identified,
            steps: out
                .steps
                .iter()
                .map(|s| StepOutcome {
                    kind: kind_name(s.kind).into(),
                    from: s.from.name().into(),
                    to: s.to.name().into(),
                    ok: s.ok,
                    duration_ms: s.duration_ms,
                })
                .collect(),
            error: out.error().map(String::from),
            fault_code: out
                .failure
                .as_ref()
                .and_then(|f| f.fault)
                .map(text::fault_code),
            failure: out.failure.as_ref().map(|f| FailureOutcome {
                kind: f.kind.name().into(),
                step: f.step.map(|s| FailedStep {
                    index: s.index,
                    total: s.total,
                    kind: kind_name(s.kind).into(),
                    from: s.from.name().into(),
                    to: s.to.name().into(),
                }),
                fault_code: f.fault.map(text::fault_code),
                fault: f.fault.map(|c| text::fault_name(c).into()),
                reject: f.reject.map(|r| text::reject_name(r).into()),
                refused: f.refusal.as_ref().map(crate::cli::Refused::of),
                message: f.message.clone(),
            }),
            sim: truth.cloned(),
        }
    }

    /// As JSON (what `plan --json` prints).
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self).unwrap_or(Value::Null)
    }
}

/// What `status` and `stop` report: one status of the device, who the device is and, for the
/// simulator, its ground truth.
pub struct Snapshot {
    /// The device's status, read after the request.
    pub status: protocol::Status,
    /// Who the device is (from the handshake).
    pub info: protocol::DeviceInfo,
    /// The simulator's ground truth, if the device is the simulator.
    pub truth: Option<SimTruth>,
    /// Through a server, after an abort: engine ms from the stop's arrival to the device's
    /// answer.
    pub abort_latency_ms: Option<u64>,
    /// The socket of the `host-tool serve` server that answered (`None`: this process talked
    /// to the device itself).
    pub server: Option<std::path::PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_document_reads_back_as_it_was_written() {
        let doc = PlanOutcome {
            ok: false,
            from: Some("F&P".into()),
            target: Some("D&D".into()),
            final_state: Some("F&F".into()),
            state_confirmed: false,
            candidates: Some(vec!["F&F".into(), "D&F".into()]),
            identified: false,
            steps: vec![StepOutcome {
                kind: "pneumatic".into(),
                from: "F&P".into(),
                to: "F&F".into(),
                ok: false,
                duration_ms: None,
            }],
            error: Some("step 1/3 aborted".into()),
            fault_code: Some("E07".into()),
            failure: Some(FailureOutcome {
                kind: "fault".into(),
                step: Some(FailedStep {
                    index: 0,
                    total: 3,
                    kind: "pneumatic".into(),
                    from: "F&P".into(),
                    to: "F&F".into(),
                }),
                fault_code: Some("E07".into()),
                fault: Some("over-pressure".into()),
                reject: None,
                refused: None,
                message: "over-pressure".into(),
            }),
            sim: Some(SimTruth {
                true_state: None,
                max_pressure_kpa: 40.5,
                pressure_limit_kpa: 40.0,
                actuators_safe: true,
            }),
        };
        let line = serde_json::to_string(&doc).expect("serialises");
        let back: PlanOutcome = serde_json::from_str(&line).expect("reads back");
        assert_eq!(back, doc);
        // Every key of the documented object, absent ones as null.
        let v = doc.to_json();
        for k in [
            "ok",
            "from",
            "target",
            "final_state",
            "state_confirmed",
            "candidates",
            "identified",
            "steps",
            "error",
            "fault_code",
            "failure",
            "sim",
        ] {
            assert!(v.get(k).is_some(), "{k} missing: {v}");
        }
        assert_eq!(v["failure"]["reject"], Value::Null);
    }
}

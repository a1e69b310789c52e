#!/usr/bin/env python3
"""Reads host-tool's MCAP recordings back with the Python `mcap` reader (PyPI), independently of
the Rust writer: channels, schemas, message counts, monotonic log times, contents.

  check_mcap.py plan FILE.mcap PLAN.json        a `plan --sim --record` run and its --json
  check_mcap.py monitor FILE.mcap MONITOR.jsonl a `monitor --json --record` run and what it printed
  check_mcap.py killed FILE.mcap RECOVERED.mcap a recording whose writer was killed, and
                                                `host-tool log recover` of it
"""
import json
import sys

from jsonschema import Draft202012Validator
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap_protobuf.decoder import DecoderFactory

TOPICS = {
    "/telemetry": "crane.Telemetry",
    "/events": "crane.Event",
    "/faults": "crane.Fault",
    "/state": "crane.State",
    "/log": "foxglove.Log",
    "/link/requests": "crane.Request",
    "/link/responses": "crane.Response",
    "/link/frames": "crane.RawFrame",
    "/plan": "crane.Plan",
    "/run": "crane.RunEvent",
    "/sim/truth": "crane.GroundTruth",
    "/scene": "foxglove.SceneUpdate",
    "/tf": "foxglove.FrameTransforms",
}
# Foxglove's well-known scene types are protobuf (their schema: the FileDescriptorSet).
PROTOBUF = {"/scene", "/tf"}

passed = 0
failed = 0


def check(cond, what):
    global passed, failed
    if cond:
        passed += 1
        print(f"ok   {what}")
    else:
        failed += 1
        print(f"FAIL {what}")


def read_all(path):
    """(summary, [(topic, schema name, log_time, data)]) in file order."""
    with open(path, "rb") as f:
        r = make_reader(f)
        summary = r.get_summary()
        protobuf = DecoderFactory()
        decoders = {}
        msgs = []
        for sch, ch, m in r.iter_messages(log_time_order=False):
            if ch.topic in PROTOBUF:
                if ch.id not in decoders:
                    decoders[ch.id] = protobuf.decoder_for(ch.message_encoding, sch)
                data = decoders[ch.id](m.data)
            else:
                data = json.loads(m.data)
            msgs.append((ch.topic, sch.name if sch else None, m.log_time, data))
    return summary, msgs


def common(path):
    summary, msgs = read_all(path)
    topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    check(topics == TOPICS, f"{path}: channels and schemas {sorted(topics)}")
    encodings = {
        c.topic: (summary.schemas[c.schema_id].encoding, c.message_encoding)
        for c in summary.channels.values()
    }
    check(
        all(e == (("protobuf", "protobuf") if t in PROTOBUF else ("jsonschema", "json"))
            for t, e in encodings.items()),
        "JSON schemas and messages; protobuf for the scene types",
    )
    validators = {}
    for c in summary.channels.values():
        if c.topic not in PROTOBUF:
            schema = json.loads(summary.schemas[c.schema_id].data)  # every JSON schema is JSON
            Draft202012Validator.check_schema(schema)
            validators[c.topic] = Draft202012Validator(schema)
    invalid = [
        (t, d, e.message)
        for t, _, _, d in msgs
        if t in validators
        for e in validators[t].iter_errors(d)
    ]
    checked = sum(1 for t, *_ in msgs if t in validators)
    check(
        not invalid,
        f"every JSON message ({checked}) validates against its channel's schema"
        + (f"; the first that does not: {invalid[0][0]} {invalid[0][2]}: {json.dumps(invalid[0][1])[:300]}"
           if invalid else ""),
    )
    counts = {}
    for t, *_ in msgs:
        counts[t] = counts.get(t, 0) + 1
    stats = summary.statistics.channel_message_counts
    by_id = {c.id: c.topic for c in summary.channels.values()}
    check(
        all(stats.get(i, 0) == counts.get(t, 0) for i, t in by_id.items()),
        f"statistics match the messages read ({len(msgs)})",
    )
    times = [lt for _, _, lt, _ in msgs]
    check(all(a <= b for a, b in zip(times, times[1:])), "log times never go back (file order)")
    tel = [d for t, _, _, d in msgs if t == "/telemetry"]
    tel_times = [lt for t, _, lt, _ in msgs if t == "/telemetry"]
    check(
        all(lt == d["device_ms"] * 1_000_000 for lt, d in zip(tel_times, tel)),
        "telemetry log time = device uptime",
    )
    logs = [d for t, _, _, d in msgs if t == "/log"]
    check(
        all(set(d) >= {"timestamp", "level", "message"} and 1 <= d["level"] <= 5 for d in logs),
        f"foxglove.Log fields ({len(logs)} lines)",
    )
    return summary, msgs, counts


def plan(path, plan_json):
    out = json.load(open(plan_json))
    _, msgs, counts = common(path)
    plans = [d for t, _, _, d in msgs if t == "/plan"]
    check(len(plans) == 1, "one plan (no replan)")
    check(
        [(s["from"], s["to"], s["kind"]) for s in plans[0]["steps"]]
        == [(s["from"], s["to"], s["kind"]) for s in out["steps"]],
        "recorded plan = the steps plan --json reports",
    )
    tel = [d for t, _, _, d in msgs if t == "/telemetry"]
    span_s = (tel[-1]["device_ms"] - tel[0]["device_ms"]) / 1000
    check(len(tel) >= 45 * span_s, f"telemetry at 50 Hz: {len(tel)} samples over {span_s:.2f} s")
    check(max(d["pressure_kpa"] for d in tel) > 20, "the pressure trace has the snaps' peaks")
    check(tel[-1]["state"] == out["final_state"], f"last sample's state {tel[-1]['state']}")
    truth = [d for t, _, _, d in msgs if t == "/sim/truth"]
    check(len(truth) >= 45 * span_s and truth[-1]["true_state"] == out["sim"]["true_state"],
          f"ground truth at 50 Hz, ends in {truth[-1]['true_state']}")
    reqs = [d for t, _, _, d in msgs if t == "/link/requests"]
    resps = [d for t, _, _, d in msgs if t == "/link/responses"]
    names = [r["name"] for r in reqs]
    check(names[0] == "Hello" and "UploadPlan" in names and "StartPlan" in names,
          f"requests decoded ({len(reqs)}: Hello … UploadPlan, StartPlan …)")
    check({r["seq"] for r in resps} <= {r["seq"] for r in reqs}, "every response answers a request")
    frames = [d for t, _, _, d in msgs if t == "/link/frames"]
    check(
        sum(1 for f in frames if f["dir"] == "tx") == len(reqs)
        and all(f["decoded"] and len(f["hex"]) == 2 * f["len"] for f in frames),
        f"raw frames ({len(frames)}), one per request sent",
    )
    done = [d for t, _, _, d in msgs if t == "/events" and d["kind"] == "step-done"]
    check(len(done) == len(out["steps"]), f"{len(done)} step-done events")
    outcome = [d for t, _, _, d in msgs if t == "/run" and d["kind"] == "outcome"]
    check(len(outcome) == 1 and outcome[0]["detail"]["ok"] is True, "the outcome is recorded")
    check(counts.get("/faults", 0) == 0, "no faults")
    scene(msgs, out["final_state"])


def scene(msgs, final_state):
    """The trunk's scene, decoded from its protobuf with the schema in the file."""
    scenes = [(lt, d) for t, _, lt, d in msgs if t == "/scene"]
    tfs = [(lt, d) for t, _, lt, d in msgs if t == "/tf"]
    tel_times = {lt for t, _, lt, _ in msgs if t == "/telemetry"}
    check(len(scenes) >= 10 and len(tfs) == len(scenes),
          f"{len(scenes)} scenes, {len(tfs)} tip transforms")
    check(all(lt in tel_times for lt, _ in scenes), "each scene stamped with its sample's time")
    ok = True
    for lt, u in scenes:
        ok &= [e.id for e in u.entities] == ["module-0", "module-1"]
        for e in u.entities:
            ok &= e.frame_id == "base"
            ok &= e.timestamp.seconds * 1_000_000_000 + e.timestamp.nanos == lt
            tri = e.triangles[0]
            ok &= len(tri.indices) % 3 == 0 and max(tri.indices) < len(tri.points)
    check(ok, "two module entities in frame base, valid triangle lists, device-time stamps")
    top = lambda u: max(p.z for e in u.entities for p in e.triangles[0].points)
    check(top(scenes[-1][1]) > top(scenes[0][1]) + 0.1,
          f"the trunk grows: {top(scenes[0][1]):.3f} m → {top(scenes[-1][1]):.3f} m")
    label = scenes[-1][1].entities[1].texts[0].text
    check(label.startswith(final_state), f"last scene's label: {label}")
    check(all(t.transforms[0].child_frame_id == "tip" for _, t in tfs), "tip frames")


def monitor(path, printed):
    lines = [json.loads(l) for l in open(printed) if l.strip()]
    samples = [l for l in lines if l["type"] == "telemetry"]
    _, msgs, _ = common(path)
    tel = [d for t, _, _, d in msgs if t == "/telemetry"]
    # The recording also has the few samples that came while monitor restored the device's
    # telemetry rate and closed the session, after its last print.
    check(len(samples) > 20 and 0 <= len(tel) - len(samples) <= 5,
          f"{len(tel)} telemetry samples recorded, {len(samples)} printed")
    # monitor prints no two samples at one displayed time, so it may leave out a sample the
    # recording keeps: match each printed sample to the recorded one of the same device time.
    by_ms = {d["device_ms"]: d for d in tel}
    same = all(
        (d := by_ms.get(s["uptime_ms"])) is not None
        and d["state"] == s["state"]
        and d["pressure_kpa"] == s["pressure_kpa"]
        and d["servo_deg"] == s["servo_deg"]
        and d["inlet_open"] == s["inlet_open"]
        and d["exhaust_open"] == s["exhaust_open"]
        for s in samples
    )
    check(same, "every sample monitor --json printed was recorded, with the same values")


def killed(path, recovered):
    # The standard reader, streaming (no summary needed), up to the last complete record.
    n = 0
    topics = set()
    error = None
    with open(path, "rb") as f:
        try:
            for rec in NonSeekingReader(f).iter_messages(log_time_order=False):
                n += 1
                topics.add(rec[1].topic)
        except (McapError, EOFError, Exception) as e:  # the truncated tail
            error = type(e).__name__
    check(n > 100 and "/telemetry" in topics,
          f"killed recording: {n} messages readable (stopped at: {error})")
    summary, msgs = read_all(recovered)
    check(len(msgs) == n, f"recovered file: complete, {len(msgs)} messages = {n} readable")
    times = [lt for _, _, lt, _ in msgs]
    check(all(a <= b for a, b in zip(times, times[1:])), "recovered log times never go back")


def main():
    kind, a, b = sys.argv[1:4]
    {"plan": plan, "monitor": monitor, "killed": killed}[kind](a, b)
    print(f"check_mcap {kind}: {passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()

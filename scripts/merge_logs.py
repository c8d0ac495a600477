#!/usr/bin/env python3
"""Merges the training logs of a chain of runs (each started with --init-from the one before) into
one log.jsonl, in order. Every line gains "run" (the run's number in the chain, from 1) and
"run_step" (its step within that run); "step" counts over the whole chain, so `mosyn report`
draws one curve. A run whose weights went on from an earlier step than its last is cut there;
"-:STEPS" stands for a run whose log is lost (its steps still count).

  scripts/merge_logs.py OUT.jsonl LOG[:LAST_STEP] ...
  scripts/merge_logs.py models/NAME/log.jsonl run-1/log.jsonl:15000 run-2/log.jsonl run/log.jsonl
"""
import json
import sys


def main(argv):
    if len(argv) < 3 or argv[1] in ("-h", "--help"):
        sys.exit(__doc__)
    lines, offset = [], 0
    for run, spec in enumerate(argv[2:], start=1):
        path, _, last = spec.partition(":")
        last = int(last) if last else None
        end = 0
        if path == "-":
            offset += last
            continue
        with open(path) as f:
            for text in f:
                if not text.strip():
                    continue
                row = json.loads(text)
                step = int(row.get("step", 0))
                if last is not None and step > last:
                    continue
                end = max(end, step)
                merged = {"run": run, "run_step": step}
                merged.update(row)
                merged["step"] = offset + step
                lines.append(json.dumps(merged, separators=(",", ":")))
        offset += last if last is not None else end
    with open(argv[1], "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"{argv[1]}: {len(lines)} lines from {len(argv) - 2} runs, {offset} steps")


if __name__ == "__main__":
    main(sys.argv)

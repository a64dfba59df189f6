"""How well the embedded model's scores pick what a command needs, per calibration mode.

    .venv/bin/python benchmarks/bench_scoring.py

For each of the catalog's commands, scores every object category (template score_objects),
every furniture category (score_target) and every room type (score_room) with the real embedded
model, and prints against the catalog's ground truth: top-5 category precision, top-1 target
furniture accuracy and top-1 room accuracy, for the three ways of combining the raw score with
the calibrated one (raw, half = raw + calibrated, cal = calibrated). The chance level of each is
printed beside it. ``interllm.planning.proposals.SCORE_MODES`` records the chosen modes.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from _usage import no_arguments  # noqa: E402  (benchmarks/_usage.py, beside this script)

from interllm.config import LLMConfig  # noqa: E402
from interllm.llm import make_client  # noqa: E402
from interllm.llm.prompts import load_template  # noqa: E402
from interllm.llm.types import ScoreRequest  # noqa: E402

CAT = ROOT / "interllm" / "scene" / "catalog"


def words(s: str) -> str:
    return s.replace("_", " ")


def main() -> None:
    cmds = json.loads((CAT / "commands.json").read_text())["commands"]
    objs = sorted(json.loads((CAT / "objects.json").read_text())["categories"])
    furn = sorted(json.loads((CAT / "furniture.json").read_text())["categories"])
    rooms = sorted(json.loads((CAT / "rooms.json").read_text())["types"])
    with tempfile.TemporaryDirectory() as tmp:
        client = make_client(LLMConfig(cache_dir=tmp))
        tasks = [
            ("categories top-5 precision", "score_objects", "Useful item:", objs, 5, lambda c: c["categories"]),
            ("target furniture top-1", "score_target", "Put them on the:", furn, 1,
             lambda c: c["target"]["furniture"]),
            ("target room top-1", "score_room", "Room:", rooms, 1,
             lambda c: [c["target"]["room_type"]] if c["target"]["room_type"] else None),
        ]
        print(f"{'what':<28}{'raw':>8}{'half':>8}{'cal':>8}{'chance':>9}")
        for label, tpl_name, query, cands, k, truth in tasks:
            tpl = load_template(tpl_name)
            res = {"raw": [], "half": [], "cal": []}
            chance = []
            for c in cmds:
                t = truth(c)
                if t is None:
                    continue
                prompt = tpl.render(known_costs="", command=c["text"], query=query).rstrip("\n")
                calp = tpl.render(known_costs="", command="N/A", query=query).rstrip("\n")
                r = client.score(ScoreRequest("bench", prompt, tuple(" " + words(x) for x in cands), calp))
                raw, cal = np.array(r.raw), np.array(r.scores)
                for mode, s in (("raw", raw), ("half", raw + cal), ("cal", cal)):
                    top = [cands[i] for i in np.argsort(-s, kind="stable")[:k]]
                    res[mode].append(np.mean([x in t for x in top]))
                chance.append(sum(x in t for x in cands) / len(cands))
            print(f"{label:<28}" + "".join(f"{np.mean(res[m]):>8.2f}" for m in ("raw", "half", "cal"))
                  + f"{np.mean(chance):>9.2f}")
        client.close()


if __name__ == "__main__":
    no_arguments(sys.argv[1:], __doc__)
    main()

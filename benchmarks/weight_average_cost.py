"""What averaging the weights costs a Q-ensemble's training step (docs/guide/skills.md#averaged-weights).

    python benchmarks/weight_average_cost.py [--extra-inputs 3] [--batch 128] [--steps 500] [--json OUT]

Times, in one process on one torch thread, an Adam step of the 8-member ensemble (batch ``--batch``,
``--extra-inputs`` screen inputs as the geometric network reads them) and one update of its
exponential weight average (``t2m train --weight-average``). Prints milliseconds per step and per
update (means over ``--steps``, after 50 warm-up steps) and their ratio; writes JSON.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extra-inputs", type=int, default=3, help="screen inputs (Push's geometric ensemble reads 3)")
    parser.add_argument("--batch", type=int, default=128)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--json", dest="json_out", type=Path, default=None)
    args = parser.parse_args()

    from t2m_core.atomic_files import write_json_atomic
    from t2m_skills_tableenv.networks import QEnsemble
    from t2m_skills_tableenv.training import WeightAverage

    torch.set_num_threads(1)
    torch.manual_seed(0)
    network = QEnsemble(extra_inputs=args.extra_inputs)
    average = WeightAverage(network, 0.999)
    optimizer = torch.optim.Adam(network.parameters(), lr=3e-4)
    inputs = torch.rand(args.batch, 96 + 4 + args.extra_inputs) - 0.5
    targets = torch.randint(2, (args.batch, 1)).float().expand(args.batch, network.members)

    def step() -> None:
        loss = torch.nn.functional.binary_cross_entropy_with_logits(network._logits(inputs), targets)  # noqa: SLF001
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()

    for _ in range(50):
        step()
        average.update()
    started = time.perf_counter()
    for _ in range(args.steps):
        step()
    step_ms = 1000 * (time.perf_counter() - started) / args.steps
    started = time.perf_counter()
    for _ in range(args.steps):
        average.update()
    update_ms = 1000 * (time.perf_counter() - started) / args.steps
    result = {
        "parameters": sum(p.numel() for p in network.parameters()),
        "batch": args.batch,
        "step_ms": round(step_ms, 3),
        "average_update_ms": round(update_ms, 4),
        "ratio": round(update_ms / step_ms, 4),
        "threads": 1,
    }
    print(f"{result['parameters']} parameters: step {step_ms:.2f} ms, average update {update_ms:.3f} ms ({100 * update_ms / step_ms:.1f} % of a step)")
    if args.json_out:
        write_json_atomic(args.json_out, result)


if __name__ == "__main__":
    main()

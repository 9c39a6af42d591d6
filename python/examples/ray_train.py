"""Train a room's models as independent Ray tasks, one per model, into one folder: the engine a
fleet of machines would use (a Ray cluster), here on the local cores.

    pip install ray
    python examples/ray_train.py ROOM OUT [--steps 300] [--cpus 2]

Each task trains one model (`Models.train(..., only=[name])`); the manifest lists every model
finished so far, whichever task finished it, and is complete once all are there. A last call
without `only` trains nothing and writes the complete manifest and the localization database.
"""

from __future__ import annotations

import argparse

import ray

import neuroom


@ray.remote(num_cpus=1)  # type: ignore[untyped-decorator]
def train_model(room: str, out: str, name: str, steps: int | None) -> str:
    """One model of the room, trained on one core."""
    neuroom.Models.train(room, out, steps=steps, only=[name], threads=1, seed=0)
    return name


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("room")
    parser.add_argument("out")
    parser.add_argument("--steps", type=int, default=None, help="steps per model")
    parser.add_argument("--cpus", type=int, default=2, help="cores Ray may use")
    args = parser.parse_args()

    ray.init(num_cpus=args.cpus)
    names = neuroom.Room(args.room).model_names
    tasks = [train_model.remote(args.room, args.out, name, args.steps) for name in names]
    for done in ray.get(tasks):
        print(f"trained {done}")
    models = neuroom.Models.train(args.room, args.out, steps=args.steps, seed=0)
    print(f"{models.path}: {len(models.names)} models, complete: {models.complete}")
    ray.shutdown()


if __name__ == "__main__":
    main()

"""Accuracy of the tail-disc detector: confusion matrices that cannot fool themselves.

For each detector variant it prints the confusion (present/uncertain/absent vs truth)
overall, per condition and per hard-negative kind on

(a) each generator's held-out seeds (the generator a learned verifier was trained on),
(b) the cross-generator split (trained on one generator, evaluated on the other), and
    generator C (:mod:`tail_check.scenes_c`, written by a third author who read neither
    A nor B; nothing is trained or tuned on it, so every figure on it is cross-generator),
(c) every real photo (``DEPOT_REAL_DATA_DIR``; none shows a disc), in two parts: the
    ``report`` part no verifier has seen, and the ``train`` part the verifiers learned
    from as negatives (printed for completeness, not evidence of generalisation).

Variants: ``baseline`` (the hand-tuned :func:`tail_check.detect`), ``confirmed`` (the
service's: each hand-tuned ``present`` confirmed by every shipped verifier,
:func:`tail_check.confirm`; also per single model), ``learned`` (the
staged pipeline alone) and ``guarded`` (hand-tuned verdict that the verifier may only
question, see :class:`tail_check.pipeline.VerdictParams`).

The hand-tuned detector has no training, so for it (a) and (b) are the same scenes.
Rendered scenes are cached under ``var/tail_cache`` (``DEPOT_TAIL_CACHE``).

Measured on branch ``tail-accuracy3`` once, on held-out seeds no one had used
(``--count 300 --offset 300``: seeds 300300-300599 of each generator; real photos 17
report + 18 train; models ``verifier_A.json`` from ``depot tail-train --generators A
--seed 1 --count 1000 --validation 200``, ``verifier_B.json`` ``--generators B --count
500 --validation 100``, ``verifier_AB.json`` ``--generators AB --count 500
--validation 100``), correct / uncertain / false present:

=========  =============  ====================  ==============  ======================
variant    A own          A scenes, B's model   B own           B scenes, A's model
=========  =============  ====================  ==============  ======================
baseline   97.0/2.0/0     (no training)         53.3/9.0/2      (no training)
learned    84.3/13.3/0    70.0/25.7/0           52.7/24.3/0     53.3/13.7/0
guarded    95.7/3.3/0     93.7/5.3/0            53.0/13.0/1     52.3/12.3/0
=========  =============  ====================  ==============  ======================

The hand-tuned detector's two false ``present`` on B (B:300498, B:300535) are
signals; ``guarded`` keeps the first with B's model. With A's model (trained on the
randomised generator A with lamps among the hard negatives) B's tail lamps, signals
and red lettering are no ``present`` any more (the earlier experiment, 4d78504, had 5
on them), but only 16 of B's 148 discs are ``present`` (33 ``uncertain``). Real
photos: no ``present`` for any variant or model. The targets (>= 95 % cross-generator)
are not met on generator B.

``--generators Aw`` reports generator A's randomised mode (its ``heldout_wide`` seeds): the
verifiers were trained on that mode's training seeds, and its lamps and lettering are
the hard negatives. Measured once on 370000-370299 (``--offset 70000``), correct /
uncertain / false ``present``: hand-tuned 65.0/10.7/2, the service 59.0/17.0/1 (A:370106,
a lit signal lamp in snow, a strict xfail test).

Run: ``.venv/bin/python -m bench.tail_accuracy [--count N] [--offset K] [--variant NAME ...]``
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

import cv2

from tail_check import DetectionResult, detect
from tail_check.confirm import CONFIRM_PARAMS, confirm_with, hold_lookalikes
from tail_check.dataset import GENERATORS, Sample, real_dir, real_photos, scenes
from tail_check.evaluate import Tally
from tail_check.pipeline import (
    PIPELINE_PROFILE,
    Candidate,
    VerdictParams,
    find_candidates,
    judge,
    load_model,
)

cv2.setNumThreads(1)
MODELS = ("A", "B", "AB")
SERVICE = "+".join(CONFIRM_PARAMS.models)
"""The service's confirmation: every one of these models must believe the region."""
Photos = dict[str, list[Sample]]


@dataclass(frozen=True)
class Seen:
    """What every variant needs of one sample, computed once: the hand-tuned verdict
    and the pipeline's candidates (each model then only scores them)."""

    sample: Sample
    candidates: list[Candidate]
    hand: DetectionResult
    held: DetectionResult
    """``hand`` after the service's holds of lettering, roundels and lamp housings
    (:func:`~tail_check.confirm.hold_lookalikes`), which every confirming model set starts
    from."""


RANDOMISED_A = "Aw"
"""Generator A's domain-randomised mode (``heldout_wide`` seeds): the verifiers were trained
on its training seeds, and its lamps and lettering are the hard negatives."""


def _held_out(generator: str, count: int, offset: int) -> list[Sample]:
    if generator == RANDOMISED_A:
        return list(scenes("A", "heldout_wide", count, offset=offset))
    return list(scenes(generator, "heldout", count, offset=offset))  # type: ignore[arg-type]


def _seen(samples: list[Sample]) -> list[Seen]:
    seen = []
    for s in samples:
        hand = detect(s.image)
        candidates = find_candidates(s.image, PIPELINE_PROFILE)[0]
        seen.append(Seen(s, candidates, hand, hold_lookalikes(s.image, hand)))
    return seen


def _tally(seen: list[Seen], variant: str, model: str | None) -> Tally:
    out = Tally()
    params = VerdictParams(combine=variant)  # type: ignore[arg-type]
    # ``A+B``: every one of these models must confirm (the service's rule).
    models = [load_model(m) for m in model.split("+")] if model is not None else []
    for item in seen:
        if model is None:
            verdict = item.hand.verdict
        elif variant == "confirmed":
            # the service's rule: look-alikes held first, then every model must confirm
            verdict = confirm_with(item.candidates, 1.0, item.held, models).verdict
        else:
            verdict = judge(item.candidates, load_model(model), params, item.hand.verdict)[0]
        out.add(item.sample, verdict)
    return out


def _report(
    variant: str,
    held: dict[str, list[Seen]],
    photos: dict[str, list[Seen]],
    models: tuple[str, ...] = MODELS,
) -> None:
    if variant == "baseline":
        for g in held:
            print("\n".join(_tally(held[g], variant, None).lines(f"baseline: generator {g}")))
        for part, ps in photos.items():
            print("\n".join(_tally(ps, variant, None).lines(f"baseline: real photos ({part})")))
        return
    if variant not in ("guarded", "learned", "confirmed"):
        raise SystemExit(
            f"unknown variant {variant!r}; use baseline, confirmed, guarded or learned"
        )
    for g in (g for g in ("A", "Aw", "B") if g in held):
        mine = g[0]  # Aw: generator A's randomised mode, whose training seeds A's model saw
        other = "B" if mine == "A" else "A"
        own = _tally(held[g], variant, mine)
        print("\n".join(own.lines(f"{variant}: generator {g}, own (trained on {mine})")))
        cross = _tally(held[g], variant, other)
        print("\n".join(cross.lines(f"{variant}: generator {g}, CROSS (trained on {other})")))
        if variant == "confirmed":  # the service's models, and one trained on both
            service = _tally(held[g], variant, SERVICE)
            title = f"{variant}: generator {g}, service (AB, A and B agree)"
            print("\n".join(service.lines(title)))
            both = _tally(held[g], variant, "AB")
            print("\n".join(both.lines(f"{variant}: generator {g}, trained on AB")))
    # Generator C: no model was trained or tuned on it, so every figure is cross-generator.
    if "C" in held:
        for name in (*models, SERVICE) if variant == "confirmed" else models:
            c = _tally(held["C"], variant, name)
            print("\n".join(c.lines(f"{variant}: generator C, CROSS (trained on {name})")))
    for name in models:
        for part, ps in photos.items():
            real = _tally(ps, variant, name)
            print("\n".join(real.lines(f"{variant}: real photos, {part} part (trained on {name})")))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=150, help="held-out scenes per generator")
    parser.add_argument(
        "--offset", type=int, default=0, help="first held-out scene (seed 300000 + offset)"
    )
    parser.add_argument(
        "--variant", nargs="+", default=["baseline", "confirmed", "learned", "guarded"]
    )
    parser.add_argument(
        "--generators",
        nargs="+",
        default=list(GENERATORS),
        choices=(*GENERATORS, RANDOMISED_A),
        help=f"{RANDOMISED_A}: generator A's randomised mode (its held-out seeds)",
    )
    parser.add_argument("--models", nargs="+", default=list(MODELS), help="for the real photos")
    args = parser.parse_args(argv)
    os.environ.setdefault("DEPOT_TAIL_CACHE", "var/tail_cache")
    t0 = time.perf_counter()
    held = {g: _seen(_held_out(g, args.count, args.offset)) for g in args.generators}
    photos = {part: _seen(list(real_photos(part))) for part in ("report", "train")}
    found = sum(len(p) for p in photos.values())
    print(f"scenes and candidates ready in {time.perf_counter() - t0:.0f} s; real photos: {found}")
    if not found:
        print(f"  (no real photos under {real_dir()}; set DEPOT_REAL_DATA_DIR)")
    for variant in args.variant:
        _report(variant, held, photos, tuple(args.models))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

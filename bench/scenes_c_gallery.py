"""Contact sheet of generator-C scenes: python -m bench.scenes_c_gallery OUT.png [N]."""

from __future__ import annotations

import sys

import cv2
import numpy as np
import numpy.typing as npt

from tail_check.scenes_c import CONDITIONS, render_scene

TILE = (400, 300)


def tile(seed: int) -> npt.NDArray[np.uint8]:
    cond = CONDITIONS[seed % len(CONDITIONS)]
    sc = render_scene(seed, disc=seed % 2 == 0, condition=cond)
    img = sc.image.copy()
    if sc.bbox is not None:
        x, y, w, h = sc.bbox
        cv2.rectangle(img, (x - 3, y - 3), (x + w + 3, y + h + 3), (0, 255, 0), 2)
    out = cv2.resize(img, TILE, interpolation=cv2.INTER_AREA)
    label = f"{seed} {sc.condition} {'DISC' if sc.disc else sc.negative_kind}"
    cv2.putText(out, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3)
    cv2.putText(out, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1)
    return np.asarray(out, dtype=np.uint8)


def main(argv: list[str]) -> int:
    if not argv:
        print("usage: python -m bench.scenes_c_gallery OUT.png [N] [FIRST_SEED]")
        return 2
    n = int(argv[1]) if len(argv) > 1 else 24
    first = int(argv[2]) if len(argv) > 2 else 0
    tiles = [tile(first + i) for i in range(n)]
    cols = 4
    while len(tiles) % cols:
        tiles.append(np.zeros_like(tiles[0]))
    rows = [np.hstack(tiles[i : i + cols]) for i in range(0, len(tiles), cols)]
    cv2.imwrite(argv[0], np.vstack(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))

"""``depot ... | head``: a reader that stops early ends depot quietly, not with a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np


def test_a_closed_pipe_ends_the_command_without_a_traceback(tmp_path: Path) -> None:
    image = np.full((480, 640, 3), (120, 100, 80), np.uint8)
    path = tmp_path / "plain.png"
    assert cv2.imwrite(str(path), image)
    # Many verdicts, read by nobody: the pipe is closed before depot writes the first.
    with subprocess.Popen(
        [sys.executable, "-m", "service.cli", "tail-check", *[str(path)] * 40],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    ) as process:
        assert process.stdout is not None and process.stderr is not None
        process.stdout.close()
        stderr = process.stderr.read().decode()
        code = process.wait(timeout=120)
    assert "Traceback" not in stderr, stderr
    assert "BrokenPipeError" not in stderr, stderr
    assert code == 141  # as a shell reports a command ended by SIGPIPE

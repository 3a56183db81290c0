"""The image that docker-compose.yml runs, built from ./Dockerfile and run here with buildah
(no Docker engine, no registry: deploy/build-image.sh --local-base builds the Debian base).

Minutes long (a base from debootstrap and every wheel from the package index on a fresh store),
so it runs only when asked: DEPOT_IMAGE_BUILD=1 with buildah and debootstrap installed, as root:
    DEPOT_IMAGE_BUILD=1 DEPOT_TEST_POSTGRES_URL=... \
        .venv/bin/pytest tests/service/test_service_image.py
(the check migrates and serves against that database; the image is localhost/depot:test).
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
from pathlib import Path

import pytest

from tests.conftest import POSTGRES_URL

ROOT = Path(__file__).resolve().parents[2]

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        os.environ.get("DEPOT_IMAGE_BUILD") != "1",
        reason="builds the image for minutes: run with DEPOT_IMAGE_BUILD=1 (buildah, root)",
    ),
    pytest.mark.skipif(shutil.which("buildah") is None, reason="buildah is not installed"),
    pytest.mark.skipif(os.geteuid() != 0, reason="buildah's chroot isolation needs root here"),
]


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_the_dockerfile_builds_an_image_that_runs_non_root_without_compiler_or_pip() -> None:
    # Its own containers store (a store made with another driver cannot be opened with this one);
    # kept between runs, so a second run reuses the base and the dependency layer.
    env = {
        "DEPOT_BUILD_ROOT": "/var/tmp/depot-image-test",
        **os.environ,
        "DEPOT_CHECK_PORT": str(_free_port()),
    }
    if POSTGRES_URL:  # then migrate and serve against it too
        env["DEPOT_DATABASE_URL"] = POSTGRES_URL
    done = subprocess.run(
        [ROOT / "deploy" / "build-image.sh", "--local-base", "--check", "--tag",
         "localhost/depot:test"],
        env=env, capture_output=True, text=True, timeout=3600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-4000:]
    assert "image checked: user 10001, no compiler, no pip, depot --help" in done.stderr
    if POSTGRES_URL:
        assert "database at head" in done.stderr
        assert 'serve: /readyz 200, /healthz {"status":"ok"}' in done.stderr, done.stderr[-2000:]

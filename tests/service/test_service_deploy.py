"""The production files: the image is multi-stage, non-root and compiler-free; the compose file
validates, builds that image, installs nothing at start and mounts no source read-write."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SECRETS = {
    "DEPOT_ADMIN_TOKEN": "h7Qm2-vXc9LpT4wZ_rB6nYk3sJd8FgA1",
    "DEPOT_DB_PASSWORD": "b" * 16,
    "PATH": "/usr/bin:/bin",
}


def _stages() -> list[list[str]]:
    stages: list[list[str]] = []
    for line in (ROOT / "Dockerfile").read_text().splitlines():
        if line.startswith("FROM "):
            stages.append([])
        if stages and line.strip() and not line.lstrip().startswith("#"):
            stages[-1].append(line.strip())
    return stages


def test_the_image_is_multi_stage_non_root_and_has_no_compiler() -> None:
    stages = _stages()
    assert len(stages) >= 2
    final = "\n".join(stages[-1])
    users = [line.split()[1] for line in stages[-1] if line.startswith("USER ")]
    assert users and users[-1].split(":")[0] not in ("root", "0")
    for tool in ("gcc", "build-essential", "pip install", "apt-get install"):
        assert tool not in final, tool
    assert "COPY --from=build /opt/depot /opt/depot" in final
    assert "COPY . " not in final  # no source tree in the final image


def _config() -> dict[str, object]:
    for command in (["docker", "compose"], ["docker-compose"]):
        if shutil.which(command[0]) is None:
            continue
        probe = subprocess.run([*command, "version"], capture_output=True, text=True)
        if probe.returncode != 0:
            continue
        done = subprocess.run(
            [*command, "-f", str(ROOT / "docker-compose.yml"), "config", "--format", "json"]
            if command == ["docker", "compose"]
            else [*command, "-f", str(ROOT / "docker-compose.yml"), "config"],
            capture_output=True,
            text=True,
            env=SECRETS,
            cwd=ROOT,
        )
        assert done.returncode == 0, done.stderr
        if command == ["docker", "compose"]:
            return dict(json.loads(done.stdout))
        yaml = pytest.importorskip("yaml")
        return dict(yaml.safe_load(done.stdout))
    pytest.skip("neither `docker compose` nor docker-compose is installed")


def test_compose_validates_and_runs_the_built_image() -> None:
    services = _config()["services"]
    assert isinstance(services, dict)
    assert {"db", "mqtt", "nats", "depot", "migrate", "caddy"} <= set(services)
    for name, service in services.items():
        command = " ".join(service.get("command") or [])
        assert "pip install" not in command, name
        for volume in service.get("volumes", []):
            spec = volume.split(":")[0] if isinstance(volume, str) else volume.get("source", "")
            read_only = volume.get("read_only") if isinstance(volume, dict) else ":ro" in volume
            if str(spec).startswith(("/", ".")) and not str(spec).endswith(("Caddyfile", ".conf")):
                pytest.fail(f"{name} mounts {spec} from the host")
            if "Caddyfile" in str(spec) or ".conf" in str(spec):
                assert read_only, f"{name}: {spec} must be read-only"
        if name.startswith(("depot", "migrate")):
            assert "build" in service and service.get("read_only") is True, name
    depot = services["depot"]
    assert depot["environment"]["DEPOT_TRUSTED_PROXIES"] == "172.28.0.10"
    assert not depot.get("ports"), "depot is reached through Caddy only"


def test_the_caddyfile_terminates_tls_for_depot() -> None:
    caddyfile = (ROOT / "deploy" / "Caddyfile").read_text()
    assert "tls internal" in caddyfile and "reverse_proxy depot:8000" in caddyfile
    caddy = shutil.which("caddy")
    if caddy is None:
        pytest.skip("caddy is not installed: the Caddyfile was not validated")
    done = subprocess.run(
        [caddy, "adapt", "--config", str(ROOT / "deploy" / "Caddyfile"), "--adapter", "caddyfile"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr

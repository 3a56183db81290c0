# depot: the service image (docker-compose.yml runs it; docs/OPERATIONS.md).
# Stage 1 builds a virtual environment from wheels; stage 2 gets only that environment:
# no compiler, no pip cache, no source tree, no tests, and a user without a login.
# BASE_IMAGE: any Debian-like image with Python 3.11 as `python` (deploy/build-image.sh builds
# one from Debian packages where no registry is reachable); both stages must use the same one.
ARG BASE_IMAGE=python:3.11-slim-bookworm

FROM ${BASE_IMAGE} AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1
RUN python -m venv /opt/depot
WORKDIR /src
# Dependencies first (a layer that changes only with pyproject.toml), then the code.
COPY pyproject.toml README.md ./
RUN mkdir -p core && touch core/__init__.py \
    && /opt/depot/bin/pip install --only-binary=:all: . \
    && /opt/depot/bin/pip uninstall --yes depot
COPY core core
COPY ingest ingest
COPY service service
COPY transports transports
COPY identification identification
COPY tail_check tail_check
COPY maintenance maintenance
COPY motion motion
COPY migrations migrations
RUN /opt/depot/bin/pip install --no-deps --only-binary=:all: . \
    && /opt/depot/bin/pip uninstall --yes pip setuptools wheel

FROM ${BASE_IMAGE}
ENV PATH=/opt/depot/bin:$PATH \
    PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    DEPOT_DATA_DIR=/data \
    DEPOT_HOST=0.0.0.0 \
    DEPOT_PORT=8000
# The base's own pip (python:3.11-slim ships one) goes too: nothing can be installed at run time.
RUN if python -m pip --version >/dev/null 2>&1; then \
        python -m pip uninstall --yes --no-input pip setuptools wheel; fi \
    && groupadd --system --gid 10001 depot \
    && useradd --system --uid 10001 --gid depot --home-dir /data --shell /usr/sbin/nologin depot \
    && mkdir -p /data/images && chown -R depot:depot /data
COPY --from=build /opt/depot /opt/depot
USER depot:depot
WORKDIR /data
EXPOSE 8000
HEALTHCHECK --interval=10s --timeout=5s --retries=12 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/readyz', timeout=4)"]
CMD ["depot", "serve", "--workers", "2"]

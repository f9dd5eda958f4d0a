# The dynamics HTTP service.
#   docker build -t dynamics .
#   docker run -p 8000:8000 -v dynamics-store:/data dynamics
# Stage 1 compiles the C++ core, builds the wheel (the bundled robots/ ship inside it) and installs it with its
# dependencies into a virtual environment, /opt/venv; stage 2 is the bare base image and that environment (no
# compiler, no sources, no pip). No warm-up step: the server is ready as soon as it has started.
#
# Offline (docs/guide/docker.md; .ci/docker_image.sh does it): three build arguments replace the public defaults,
#   BUILD_IMAGE    the build stage's base; one that has g++ and Python's headers skips apt
#   BASE_IMAGE     the runtime's base, the same Python at the same path as BUILD_IMAGE (the venv links to it)
#   PIP_INDEX_URL  where pip finds every package, the build's own (scikit-build-core, nanobind, cmake, ninja)
#                  included: a PEP 503 directory in the build context is seen as file:///context/<its path>
# Needs BuildKit (the default builder since Docker 23; DOCKER_BUILDKIT=1 before): the context is mounted, not
# copied, into the one step that reads the package source.
ARG BUILD_IMAGE=python:3.11-slim
ARG BASE_IMAGE=python:3.11-slim

FROM ${BUILD_IMAGE} AS build
ARG PIP_INDEX_URL=https://pypi.org/simple
# the one thing the build needs from the system: a C++ compiler (python:3.11-slim has Python's headers already)
# hadolint ignore=DL3008
RUN command -v g++ >/dev/null \
    || { apt-get update \
         && apt-get install -y --no-install-recommends g++ \
         && rm -rf /var/lib/apt/lists/*; }
WORKDIR /src
COPY pyproject.toml README.md CMakeLists.txt ./
COPY core/ core/
COPY bindings/ bindings/
COPY dynamics/ dynamics/
COPY service/ service/
COPY robots/ robots/
# pip builds the wheel in an isolated environment (PIP_INDEX_URL reaches it too) and installs it; then pip and
# setuptools leave the environment (nothing in the runtime installs anything), and so does NumPy's own test
# suite
RUN --mount=type=bind,target=/context \
    python3 -m venv /opt/venv \
    && /opt/venv/bin/pip install --no-cache-dir . \
    && /opt/venv/bin/pip uninstall --yes pip setuptools \
    && find /opt/venv/lib/python3*/site-packages/numpy -depth -type d -name tests -exec rm -rf {} +

FROM ${BASE_IMAGE}
ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    DYNAMICS_STORE=/data \
    PATH=/opt/venv/bin:$PATH
COPY --from=build /opt/venv/ /opt/venv/
RUN groupadd --gid 10001 dynamics \
    && useradd --create-home --uid 10001 --gid 10001 dynamics \
    && mkdir -p /data \
    && chown 10001:10001 /data
USER 10001:10001
WORKDIR /home/dynamics
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=10s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8000/v1/health', timeout=4).status != 200)"]
CMD ["python", "-m", "service", "--host", "0.0.0.0", "--port", "8000", "--store", "/data"]

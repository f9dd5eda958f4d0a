# The dynamics HTTP service.
#   docker build -t dynamics .
#   docker run -p 8000:8000 -v dynamics-store:/data dynamics
# Stage 1 compiles the C++ core and builds the wheel (the bundled robots/ ship inside it); stage 2 installs it
# (no compiler, no sources). No warm-up step: the server is ready as soon as it has started.
FROM python:3.11-slim AS build
# the one thing the build needs from the system: a C++ compiler (every other build requirement comes from PyPI)
# hadolint ignore=DL3008
RUN apt-get update \
    && apt-get install -y --no-install-recommends g++ \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /src
RUN pip install --no-cache-dir build==1.2.2
COPY pyproject.toml README.md CMakeLists.txt ./
COPY core/ core/
COPY bindings/ bindings/
COPY dynamics/ dynamics/
COPY service/ service/
COPY robots/ robots/
RUN python -m build --wheel --outdir /dist .

FROM python:3.11-slim
ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    DYNAMICS_STORE=/data
COPY --from=build /dist/ /tmp/dist/
RUN pip install --no-cache-dir /tmp/dist/*.whl \
    && rm -rf /tmp/dist \
    && groupadd --gid 10001 dynamics \
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

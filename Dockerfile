# footfall: REST API on 8000, studio (viser) on 8080.
#
#   docker build -t footfall .
#   docker run -p 8000:8000 -p 8080:8080 footfall
#   docker run -p 8000:8000 -p 8080:8080 -e FOOTFALL_API_TOKEN=choose-a-long-token footfall
#
# Inside the container the service binds 0.0.0.0, so the token rule applies: requests that write or drive (save a
# maneuver, start a session or a simulation, preview in the studio) need the X-Footfall-Token header. Without
# FOOTFALL_API_TOKEN the server makes one up at start and prints it in the container's log (docker logs). The image
# does NOT set FOOTFALL_ALLOW_OPEN=1: a published port is reachable from the network. On a trusted network, pass
# `-e FOOTFALL_ALLOW_OPEN=1` to drop the token. User maneuvers live in the volume below.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

RUN useradd --create-home --uid 10001 --shell /usr/sbin/nologin footfall

WORKDIR /app
# Only what the service needs (the build context may hold a virtualenv and test artifacts).
COPY pyproject.toml README.md ./
COPY planning ./planning
COPY server ./server
COPY benchmarks ./benchmarks
COPY maneuvers ./maneuvers
COPY sweeps ./sweeps
COPY web ./web
RUN pip install -e .

USER footfall
ENV FOOTFALL_DATA_DIR=/home/footfall/.local/share/footfall
RUN mkdir -p "$FOOTFALL_DATA_DIR/maneuvers"
VOLUME ["/home/footfall/.local/share/footfall"]

EXPOSE 8000 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=40s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=4).status != 200)"]

CMD ["footfall", "serve", "--host", "0.0.0.0", "--port", "8000", "--viewer-port", "8080"]

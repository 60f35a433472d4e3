# The race server on embedded defaults (SQLite in /data, local planner workers), one uvicorn worker.
# EXTRAS picks the optional dependencies: "rl" (the default: the learned agents), "rl,tournament" for the images
# of the Ray head and workers (docker-compose.yml's "ray" profile).
FROM python:3.11-slim

ARG EXTRAS=rl

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    XDG_CACHE_HOME=/var/cache/karting \
    KARTING_HOST=0.0.0.0 \
    KARTING_PORT=8000 \
    KARTING_DATABASE_URL=sqlite:////data/karting.db

WORKDIR /app

# gcc for the packages that build from source; torch from the CPU index (the default index pulls CUDA builds)
RUN apt-get update -q \
    && apt-get install -y -q --no-install-recommends gcc \
    && rm -rf /var/lib/apt/lists/* \
    && pip install "torch==2.13.0" --index-url https://download.pytorch.org/whl/cpu

# every package pyproject.toml installs (tests/test_deployment.py checks this list against it)
COPY pyproject.toml README.md ./
COPY karting ./karting
COPY sim_core ./sim_core
COPY controllers ./controllers
COPY arena ./arena
COPY server ./server
COPY web ./web
RUN pip install ".[${EXTRAS}]" \
    && useradd --create-home --uid 1000 karting \
    && mkdir -p /data /var/cache/karting \
    && chown karting /data /var/cache/karting

USER karting
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=90s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/tracks', timeout=4)"
CMD ["karting", "serve"]

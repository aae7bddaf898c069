# One image for every ACNMP process; docker-compose.yml picks the process with `acnmp serve <process>`.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    RERUN_ANALYTICS=0 \
    OMP_NUM_THREADS=1

WORKDIR /app

# torch first, from the CPU index: a plain `pip install torch` would pull a multi-GB CUDA build
RUN pip install --index-url https://download.pytorch.org/whl/cpu torch==2.13.0

COPY pyproject.toml README.md ./
COPY acnmp_core ./acnmp_core
COPY services ./services
COPY clients ./clients
RUN pip install .

# checkpoints/state and recordings live on volumes (see docker-compose.yml)
RUN mkdir -p /data/state /data/recordings /data/checkpoints
VOLUME ["/data/state", "/data/recordings", "/data/checkpoints"]

ENTRYPOINT ["acnmp"]
CMD ["--help"]

# One image for every LLM-Land service; compose.yaml picks the command per container.
FROM python:3.11-slim
RUN apt-get update && apt-get install -y --no-install-recommends build-essential libegl1 libgl1 \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /opt/llmland
COPY . .
RUN bash scripts/install.sh
ENV PATH=/opt/llmland/.venv/bin:$PATH PYTHONUNBUFFERED=1
CMD ["llmland-router"]

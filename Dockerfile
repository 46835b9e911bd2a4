# syntax=docker/dockerfile:1
# Two images for docker-compose.yml: the SPARQL server (target `sparql`) and the nFEX service (the default,
# last stage), several replicas of which share that server.
ARG OXIGRAPH_VERSION=0.5.13

# Oxigraph's image is distroless (no shell, no HTTP client): a static busybox gives its healthcheck a wget.
FROM busybox:1.37-uclibc AS busybox
FROM ghcr.io/oxigraph/oxigraph:${OXIGRAPH_VERSION} AS sparql
COPY --from=busybox /bin/busybox /usr/local/bin/busybox

FROM python:3.11-slim AS service
# a regular (non-editable) install: the wheel carries ontology/, rules/ and models/ (pyproject's force-include)
WORKDIR /src
COPY pyproject.toml README.md ./
COPY nfex_core ./nfex_core
COPY service ./service
COPY cli ./cli
COPY clients/slam/nfex_slam ./clients/slam/nfex_slam
COPY ontology ./ontology
COPY rules ./rules
COPY models ./models
RUN pip install --no-cache-dir . && rm -rf /src
RUN useradd --create-home --uid 10001 nfex
USER nfex
WORKDIR /home/nfex
# compute the seed once, here (nfex_core/knowledge/seed_content.py caches it by content): an empty store then seeds in about
# a second at the first start instead of recomputing ontology/ and rules/
RUN NFEX_STORE=/tmp/nfex-seed-warmup nfex kg seed && rm -rf /tmp/nfex-seed-warmup
ENV NFEX_HOST=0.0.0.0 NFEX_PORT=8000
EXPOSE 8000
CMD ["nfex", "serve", "--host", "0.0.0.0", "--port", "8000"]

# The nFEX service image. docker-compose.yml runs several of these against one SPARQL server.
FROM python:3.11-slim
WORKDIR /app
COPY pyproject.toml README.md ./
COPY nfex_core ./nfex_core
COPY service ./service
COPY ontology ./ontology
COPY rules ./rules
COPY models ./models
RUN pip install --no-cache-dir -e .
ENV NFEX_HOST=0.0.0.0 NFEX_PORT=8000 NFEX_HOME=/app
EXPOSE 8000
CMD ["nfex", "serve", "--host", "0.0.0.0", "--port", "8000"]

# syntax=docker/dockerfile:1
#
# relight as a container.
#   docker build -t relight .                  # runtime image; bakes at first start
#   docker build -t relight:baked --target baked .   # scenes baked in: starts ready
#   docker run -p 8080:8080 -v relight-cache:/cache relight
#
# Scenes live in /app/scenes and the cache in /cache; mount volumes over either.
# Configuration is by environment (RELIGHT_ADDR, RELIGHT_SCENES, RELIGHT_CACHE,
# RELIGHT_READ_ONLY, RELIGHT_LOG, ...; `relight serve --help` lists them all).

# ---- build: the release binary (`cargo build --release`).
FROM rust:1.95-slim-bookworm AS build
# The meshopt crate (glTF EXT_meshopt_compression) compiles meshoptimizer's C++ source.
RUN apt-get update \
    && apt-get install -y --no-install-recommends g++=4:12.2.0-3 \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY Cargo.toml Cargo.lock ./
COPY src ./src
COPY benches ./benches
COPY examples ./examples
COPY tests ./tests
RUN cargo build --release --locked --bin relight \
    && strip target/release/relight

# ---- bake: the bundled scenes' transfers, for the baked image.
FROM build AS bake
COPY scenes ./scenes
RUN ./target/release/relight bake --all --scenes scenes --cache /cache

# ---- base runtime: a slim Debian with the binary, the scenes and the web page.
FROM debian:bookworm-slim AS base
RUN groupadd --system --gid 10001 relight \
    && useradd --system --uid 10001 --gid relight --home-dir /app --shell /usr/sbin/nologin relight \
    && mkdir -p /app /cache \
    && chown relight:relight /cache
COPY --from=build /src/target/release/relight /usr/local/bin/relight
COPY scenes /app/scenes
COPY static /app/static
WORKDIR /app
ENV RELIGHT_ADDR=0.0.0.0:8080 \
    RELIGHT_SCENES=/app/scenes \
    RELIGHT_CACHE=/cache \
    RELIGHT_STATIC=/app/static \
    RELIGHT_LOG=info
EXPOSE 8080
HEALTHCHECK --interval=15s --timeout=5s --start-period=10s --retries=3 \
    CMD ["relight", "health"]
ENTRYPOINT ["relight"]
CMD ["serve"]

# ---- baked: base plus the baked cache, so containers start ready (`--target baked`).
FROM base AS baked
COPY --from=bake --chown=relight:relight /cache /cache
USER 10001:10001
VOLUME ["/cache"]

# ---- runtime (default): bakes into the /cache volume on first start.
FROM base AS runtime
USER 10001:10001
VOLUME ["/cache"]

# riskplan server image: Debian 12 packages only, nothing downloaded at run time.
#
#   docker build -t riskplan .
#   docker run -p 50051:50051 riskplan                      # built-in demo-city
#   docker run -p 50051:50051 -v $PWD/maps:/maps riskplan --maps=/maps
FROM debian:12 AS build
WORKDIR /src
COPY scripts/install-deps.sh scripts/install-deps.sh
RUN bash scripts/install-deps.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DRISKPLAN_BUILD_TESTS=OFF -DRISKPLAN_BUILD_BENCH=OFF \
 && cmake --build build \
 && strip build/bin/*

FROM debian:12-slim
# The shared libraries the binaries link against (gRPC, Protobuf, abseil,
# prometheus-cpp, OpenSSL, libpng, GDAL, PROJ, and cpp-httplib for riskplan-web),
# resolved from the build stage's binaries; scripts/image-build.sh checks that
# every one resolves here (docs/deploy.md).
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
      libgrpc++1.51 libprotobuf32 libabsl20220623 libssl3 libpng16-16 \
      libprometheus-cpp-core1.0 libprometheus-cpp-pull1.0 libgdal32 libproj25 \
      libcpp-httplib0.11 ca-certificates \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --system --uid 10001 riskplan
COPY --from=build /src/build/bin/ /usr/local/bin/
USER riskplan
EXPOSE 50051 8081 9464
ENTRYPOINT ["/usr/local/bin/riskplan-server", "--listen=0.0.0.0:50051"]

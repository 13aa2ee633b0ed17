# The two commands that work on a fresh Debian machine with Rust:
#   make run    builds mpm-cli, runs the default scene (2D dam break) into out/dam_break and
#               renders every snapshot to out/dam_break/render/frame_NNNNNN.png
#   make test   runs the whole test suite (cargo test --workspace --release): the release
#               profile, so it reuses what `make run` built instead of compiling everything again
# Both first install libhdf5-dev and pkg-config with apt-get when pkg-config cannot find HDF5
# (with sudo unless already root).

CARGO ?= cargo
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: run test deps

deps:
	@if ! pkg-config --exists hdf5 2>/dev/null; then \
		echo "==> installing libhdf5-dev and pkg-config (HDF5 not found by pkg-config)"; \
		$(SUDO) apt-get update -qq && \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libhdf5-dev pkg-config; \
	fi

run: deps
	$(CARGO) build --release -p mpm-cli
	$(CARGO) run --release -q -p mpm-cli -- run scenes/dam_break_2d.toml --out out/dam_break
	$(CARGO) run --release -q -p mpm-cli -- render out/dam_break --all > /dev/null
	@echo "snapshots, run.xmf and summary.json in out/dam_break; pictures in out/dam_break/render/"

test: deps
	$(CARGO) test --workspace --release

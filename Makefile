# The two commands that work on a fresh Debian machine with Rust:
#   make run    builds mpm-cli, runs the default scene (2D dam break) into out/dam_break and
#               renders every snapshot to out/dam_break/render/frame_NNNNNN.png
#   make test   runs the whole test suite (cargo test --workspace --release): the release
#               profile, so it reuses what `make run` built instead of compiling everything again
# Both first install libhdf5-dev and pkg-config with apt-get when pkg-config cannot find HDF5
# (with sudo unless already root).

CARGO ?= cargo
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: run test deps mpi-deps mpi-test

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

# The distributed explicit solver under MPI (docs/distributed.md): installs Open MPI and libclang
# (rsmpi's bindings) when missing, lints with the `mpi` features, builds mpm-cli and the MPI
# check with them, runs the library's identity check on 1, 2, 3 and 4 ranks (more ranks than
# cores: --oversubscribe, 1 thread each) and mpm-cli under mpirun against one process.
# Afterwards target/release/mpm-cli links MPI; `make run` rebuilds the default one.
MPIRUN ?= mpirun --allow-run-as-root --oversubscribe
export MPIRUN

mpi-deps:
	@if ! command -v mpirun >/dev/null 2>&1 || ! command -v mpicc >/dev/null 2>&1 || \
	    ! ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1; then \
		echo "==> installing libopenmpi-dev, openmpi-bin and libclang-dev"; \
		$(SUDO) apt-get update -qq && \
		$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
			libopenmpi-dev openmpi-bin libclang-dev; \
	fi

mpi-test: deps mpi-deps
	$(CARGO) clippy --workspace --all-targets --features mpm-cli/mpi -- -D warnings
	$(CARGO) build --release --workspace --bins --examples --features mpm-cli/mpi
	for n in 1 2 3 4; do \
		RAYON_NUM_THREADS=1 $(MPIRUN) -n $$n target/release/examples/mpi_check identity || exit 1; \
	done
	scripts/mpi_cli_check.sh target/release/mpm-cli

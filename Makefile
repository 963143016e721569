# The short hand a person types. meson.build is the build of record (pip install -e .
# runs it); these targets add the strict C build, the sanitizer run, the firmware
# image and the benchmarks.
#
#   make setup        install everything a fresh Debian machine needs (apt-get + pip)
#   make test         the whole suite: strict C build, pytest (firmware under QEMU included),
#                     again under ASan+UBSan, again against the smallest -D configuration
#   make check SAN=1  the pytest suite against a copy of the extension built with ASan+UBSan
#   make firmware     Cortex-M3/M7 images, size table, forbidden-symbol check
#   make bench        C vs reference per stage, plus callgrind instructions per pixel
#   make check SAN=1 CC=clang   the same with clang's sanitizers (its own runtime preloaded)
#   make fuzz         libFuzzer harnesses (fuzz/), FUZZ_SECONDS each; make fuzz-long: >= 10 M runs each
#   make soak         the tracker, then the pipeline, over SOAK_FRAMES synthetic frames each, C only

PY      ?= python3
CC      ?= cc
BUILD   ?= build
SAN     ?= 0
STRICT  := -std=c99 -pedantic -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes \
           -Wmissing-prototypes -Wcast-qual -Wdouble-promotion -Wfloat-equal
CORE_SRCS := $(wildcard c/*.c)
CORE_HDRS := $(wildcard include/vehtrack/*.h) $(wildcard c/*.h) $(wildcard c/tables/*.h)

.PHONY: all lib setup test pytest check firmware firmware-run bench clean tables

all: lib

# The core alone, with the strictest flags, as a firmware engineer would build it.
lib: $(BUILD)/libvehtrack.a
$(BUILD)/libvehtrack.a: $(CORE_SRCS) $(CORE_HDRS)
	@mkdir -p $(BUILD)/obj
	@set -e; for f in $(CORE_SRCS); do \
	  $(CC) $(STRICT) -O2 -Iinclude -c $$f -o $(BUILD)/obj/$$(basename $$f .c).o; done
	ar rcs $@ $(BUILD)/obj/*.o
	@echo "strict C99 build: OK ($(words $(CORE_SRCS)) sources)"

# System packages: the ARM toolchain and QEMU for the firmware proof, valgrind for
# `make bench`, chromium for the report page test. Python: the build backend first, then the package in editable mode
# (meson-python rebuilds the C on import, so it needs no build isolation).
APT_PKGS := gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm valgrind chromium \
            clang libclang-rt-14-dev gcc-multilib
SUDO     := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
setup:
	@missing=""; for t in arm-none-eabi-gcc qemu-system-arm valgrind chromium clang; do \
	  command -v $$t >/dev/null || missing="$$missing $$t"; done; \
	[ -f "$$(clang -print-file-name=libclang_rt.fuzzer-x86_64.a 2>/dev/null)" ] || missing="$$missing libclang-rt"; \
	[ -f /usr/include/x86_64-linux-gnu/gnu/stubs-32.h ] || [ -f /usr/include/gnu/stubs-32.h ] || missing="$$missing gcc-multilib"; \
	if [ -n "$$missing" ]; then echo "installing system packages for:$$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq \
	    --no-install-recommends $(APT_PKGS) >/dev/null; fi
	$(PY) -m pip install -q --upgrade "meson-python>=0.15" "meson>=1.1" ninja "cffi>=1.16"
	$(PY) -m pip install -q --no-deps "trackeval==1.3.0"
	$(PY) -m pip install -q --no-build-isolation -e ".[test]"

tables:
	$(PY) tools/gen_tables.py
	$(PY) tools/gen_cnn_table.py

# The smallest sensible build: one track slot, VGA-sized frames at most; and the
# portable C loops where the x86 builds take SSE2 / AVX2 / AVX-VNNI / AVX-512 VNNI (c/cnn.c), so the suite runs all five.
SMALL_DEFS := -DVT_MAX_TRACKS=1 -DVT_MAX_WIDTH=700 -DVT_MAX_HEIGHT=500 -DVT_NO_SIMD

# The sanitized suite runs once per compiler in SAN_COMPILERS (about a minute
# each): clang's UBSan catches signed negations gcc 12's misses, gcc's ASan
# differs in its interceptors. Then the fuzzers, FUZZ_SECONDS each.
SAN_COMPILERS ?= gcc clang
# c/cnn.c takes AVX-512 VNNI, AVX-VNNI, AVX2 or SSE2, whichever the CPU has (the main
# suite: the best). The gcc sanitized suite is built without the AVX2 paths, the clang
# one without the VNNI ones, and the CNN's tests run once more without AVX-512, so the
# SSE2, AVX2 and 256-bit AVX-VNNI paths keep being run (the smallest build runs the
# portable loops).
SAN_GCC_DEFS    ?= -DVT_NO_AVX2
SAN_CLANG_DEFS  ?= -DVT_NO_AVXVNNI
CNN_TESTS       ?= tests/test_cnn.py tests/test_cnn_band.py tests/test_cnn_upband.py
# The first suite runs everything; the sanitized (gcc and clang side by side, one core
# each) and small-configuration runs are "secondary": they leave out the modules that do
# not depend on the extension's build (tests/conftest.py, BUILD_INDEPENDENT) and draw
# SECONDARY_EXAMPLES hypothesis examples per test instead of 150, to keep CI under 20 min.
SECONDARY_EXAMPLES ?= 60
CI_FUZZ_SECONDS    ?= 6
test: lib
	$(PY) -m pytest -q
	@set -e; pids=""; for c in $(SAN_COMPILERS); do \
	  defs=""; [ $$c = gcc ] && defs="$(SAN_GCC_DEFS)"; [ $$c = clang ] && defs="$(SAN_CLANG_DEFS)"; \
	  $(MAKE) --no-print-directory check SAN=1 CC=$$c SECONDARY=1 CHECK_DEFS="$$defs" > $(BUILD)/test-san-$$c.log 2>&1 & pids="$$pids $$!"; done; \
	  rc=0; for p in $$pids; do wait $$p || rc=1; done; \
	  for c in $(SAN_COMPILERS); do echo "== sanitized suite ($$c)"; grep -v '^\.*  *\[' $(BUILD)/test-san-$$c.log | tail -n 40; done; \
	  exit $$rc
	$(MAKE) check CHECK_DEFS="$(SMALL_DEFS)" SECONDARY=1
	$(MAKE) check CHECK_DEFS=-DVT_NO_AVX512 TESTS="$(CNN_TESTS)"
	$(MAKE) -j2 fuzz-build
	$(MAKE) fuzz FUZZ_SECONDS=$(CI_FUZZ_SECONDS)

pytest:
	$(PY) -m pytest -q

# ---- the suite against an out-of-meson build of the extension (sanitizers, -D configs)
EXT_SUFFIX := $(shell $(PY) -c "import sysconfig; print(sysconfig.get_config_var('EXT_SUFFIX'))")
PY_INC     := $(shell $(PY) -c "import sysconfig; print(sysconfig.get_paths()['include'])")
CHECK_DEFS ?=
# A -D configuration gets its own build dir, so builds of different configs never mix;
# a sanitized build also names its compiler (gcc's and clang's runtimes differ).
CC_NAME    := $(shell $(CC) --version 2>/dev/null | head -1 | grep -qi clang && echo clang || echo gcc)
CHECK_DIR  := $(BUILD)/check$(if $(filter 1,$(SAN)),-san$(if $(filter clang,$(CC_NAME)),-clang,),)$(if $(strip $(CHECK_DEFS)),-$(shell echo '$(CHECK_DEFS)' | md5sum | cut -c1-8),)
CHECK_EXT  := $(CHECK_DIR)/_vtffi$(EXT_SUFFIX)
ifeq ($(SAN),1)
SAN_FLAGS  := -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -g
# The preloaded runtime follows the compiler: gcc's libasan + libubsan, or clang's
# ASan runtime (which carries its UBSan too). clang's UBSan flags signed negations
# gcc 12's does not (issue 11), so `make test` runs the clang suite.
ifeq ($(CC_NAME),clang)
SAN_PRELOAD := $$($(CC) -print-file-name=libclang_rt.asan-x86_64.so)
else
SAN_PRELOAD := $$($(CC) -print-file-name=libasan.so) $$($(CC) -print-file-name=libubsan.so)
endif
SAN_ENV    := LD_PRELOAD="$(SAN_PRELOAD)" \
              ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
endif

$(CHECK_EXT): $(CORE_SRCS) $(CORE_HDRS) $(wildcard pyvehtrack/cdef/*.h) tools/build_ffi.py
	@mkdir -p $(CHECK_DIR)
	$(PY) tools/build_ffi.py $(CHECK_DIR)/_vtffi.c >/dev/null
	$(CC) -shared -fPIC -O1 $(SAN_FLAGS) $(CHECK_DEFS) -Iinclude -I$(PY_INC) \
	  $(CORE_SRCS) $(CHECK_DIR)/_vtffi.c -o $@

TESTS ?= tests
SECONDARY ?=
check: $(CHECK_EXT)
	$(SAN_ENV) $(if $(filter 1,$(SECONDARY)),VT_SECONDARY_RUN=1 VT_HYP_EXAMPLES=$(SECONDARY_EXAMPLES),) PYTHONPATH=$(CURDIR) PYVEHTRACK_FFI=$(abspath $(CHECK_EXT)) $(PY) -m pytest -q \
	  -p no:cacheprovider $(TESTS)

# ---- soak: the tracker (tests/c/soak.c), then the whole pipeline with flow and
# hand-over (tests/c/soak_pipeline.c), each over SOAK_FRAMES synthetic frames, C only
SOAK_FRAMES ?= 1000000
SOAK_SEED   ?= 1
.PHONY: soak
$(BUILD)/soak $(BUILD)/soak_pipeline: $(BUILD)/%: tests/c/%.c tests/c/soak_scene.h $(CORE_SRCS) $(CORE_HDRS)
	@mkdir -p $(BUILD)
	$(CC) -std=c99 -O2 -Wall -Wextra -Werror -Iinclude $< $(CORE_SRCS) -o $@
soak: $(BUILD)/soak $(BUILD)/soak_pipeline
	@set -e; for d in soak soak_pipeline; do start=$$(date +%s); $(BUILD)/$$d $(SOAK_FRAMES) $(SOAK_SEED); \
	  echo "$$d: $$(( $$(date +%s) - start )) s wall"; done

-include firmware_demo/firmware.mk
-include bench/bench.mk
-include fuzz/fuzz.mk

clean:
	rm -rf $(BUILD)

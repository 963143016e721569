# fuzz/fuzz.mk -- included by the top Makefile (issue 11, item 1).
#
#   make fuzz        build every fuzz/fuzz_*.c with clang's libFuzzer + ASan + UBSan
#                    (UB fatal) and run each for FUZZ_SECONDS (default 20) from a
#                    copy of its seed corpus fuzz/corpus/NAME/; fails on any crash.
#   make fuzz-long   each harness for FUZZ_RUNS executions (default 10 M), one at a
#                    time at nice 19 (FUZZ_LONG_SECONDS caps each); logs and final
#                    stats in build/fuzz-long/NAME-long.log. FUZZ_LONG_NAMES picks
#                    harnesses (two make calls with disjoint lists use both cores).
#                    Its build (build/fuzz-long/) is -O2 without comparison tracing
#                    (-fno-sanitize-coverage=trace-cmp): 3-4x the executions per
#                    second; ASan + UBSan and UB-fatal are unchanged.
#   make fuzz-NAME   one harness, FUZZ_SECONDS.
# A crash leaves its input in build/fuzz/crash-NAME-*; replay it with
# build/fuzz/fuzz_NAME <file>. Adding a harness is adding fuzz/fuzz_NAME.c (and
# seeds in fuzz/corpus/NAME/): nothing to register.

FUZZ_CC      ?= clang
comma        := ,
FUZZ_SECONDS ?= 20
FUZZ_RUNS    ?= 10000000
# fuzz-long stops a harness after FUZZ_LONG_SECONDS too when set (0: no limit), for a
# shared machine; the report then states the executions actually reached.
FUZZ_LONG_SECONDS ?= 0
FUZZ_FLAGS   := -std=c99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
                -fno-omit-frame-pointer -Wall -Wextra -Werror -Wno-unused-function
FUZZ_OUT     := $(BUILD)/fuzz
FUZZ_SRCS    := $(sort $(wildcard fuzz/fuzz_*.c))
# A harness whose first line says "fuzz-requires: vehtrack/X.h" is built only
# where include/vehtrack/X.h exists (a stage another branch adds).
fuzz_req      = $(shell sed -n '1s|.*fuzz-requires: *\([^ ]*\).*|\1|p' $(1))
FUZZ_NAMES   ?= $(foreach s,$(FUZZ_SRCS),$(if $(or $(if $(call fuzz_req,$(s)),,1),$(wildcard include/$(call fuzz_req,$(s)))),$(patsubst fuzz/fuzz_%.c,%,$(s))))
FUZZ_BINS    := $(addprefix $(FUZZ_OUT)/fuzz_,$(FUZZ_NAMES))
# -max_len: enough for a 48x48 raw frame and its arguments. -rss_limit_mb and
# -timeout make a leak or a hang a failure, not a stall.
FUZZ_OPTS    := -max_len=8192 -rss_limit_mb=2048 -timeout=20 -print_final_stats=1
FUZZ_ENV     := ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

.PHONY: fuzz fuzz-long fuzz-build $(addprefix fuzz-,$(FUZZ_NAMES))

# The core is compiled once (instrumented, without libFuzzer's main: fuzzer-no-link)
# and every harness links those objects: all harnesses cost one core build.
FUZZ_CORE_FLAGS := $(subst -fsanitize=fuzzer$(comma),-fsanitize=fuzzer-no-link$(comma),$(FUZZ_FLAGS))
FUZZ_OBJS    := $(patsubst c/%.c,$(FUZZ_OUT)/obj/%.o,$(CORE_SRCS))
# Keep them between builds (make would delete them as intermediates).
.SECONDARY: $(FUZZ_OBJS)

$(FUZZ_OUT)/obj/%.o: c/%.c $(CORE_HDRS)
	@command -v $(FUZZ_CC) >/dev/null || { echo "fuzz: $(FUZZ_CC) not found; run 'make setup' (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
	@mkdir -p $(FUZZ_OUT)/obj
	$(FUZZ_CC) $(FUZZ_CORE_FLAGS) -Iinclude -c $< -o $@

$(FUZZ_OUT)/fuzz_%: fuzz/fuzz_%.c fuzz/fuzz.h $(FUZZ_OBJS)
	$(FUZZ_CC) $(FUZZ_FLAGS) -Iinclude -Ifuzz $< $(FUZZ_OBJS) -o $@

fuzz-build: $(FUZZ_BINS)

# One harness ($$n): a scratch copy of the seeds (new inputs never touch the
# checked-in corpus), then libFuzzer with the options in $$opts; crashes land in
# $(FUZZ_OUT)/crash-NAME-*. Used by every target below.
FUZZ_RUN_ONE = rm -rf $(FUZZ_OUT)/work-$$n && mkdir -p $(FUZZ_OUT)/work-$$n && \
  echo "== fuzz $$n: $$opts ==" && \
  ( cd $(FUZZ_OUT) && $(FUZZ_ENV) $$pre ./fuzz_$$n $(FUZZ_OPTS) $$opts -artifact_prefix=crash-$$n- \
      work-$$n $(CURDIR)/fuzz/corpus/$$n > $$n$$suf.log 2>&1 ) || \
  { tail -40 $(FUZZ_OUT)/$$n$$suf.log; echo "fuzz $$n: FAILED (see $(FUZZ_OUT)/$$n$$suf.log)" >&2; exit 1; }; \
  grep -E "stat::number_of_executed_units|Done [0-9]+ runs" $(FUZZ_OUT)/$$n$$suf.log | tr '\n' ' '; echo

$(addprefix fuzz-,$(FUZZ_NAMES)): fuzz-%: $(FUZZ_OUT)/fuzz_%
	@n=$*; opts="-max_total_time=$(FUZZ_SECONDS)"; pre=""; suf=""; $(FUZZ_RUN_ONE)

fuzz: $(FUZZ_BINS)
	@set -e; for n in $(FUZZ_NAMES); do opts="-max_total_time=$(FUZZ_SECONDS)"; pre=""; suf=""; \
	  $(FUZZ_RUN_ONE); done
	@echo "fuzz: $(words $(FUZZ_NAMES)) harnesses x $(FUZZ_SECONDS) s, no crash"

# The long campaign's build: same sources and sanitizers, -O2, no trace-cmp (the
# pixel loops' comparisons dominated the run time and rarely guide: 4x the rate).
FUZZ_LONG_OUT   := $(BUILD)/fuzz-long
FUZZ_LONG_XFLAGS := -O2 -fno-sanitize-coverage=trace-cmp
FUZZ_LONG_NAMES ?= $(FUZZ_NAMES)
FUZZ_LONG_OBJS  := $(patsubst c/%.c,$(FUZZ_LONG_OUT)/obj/%.o,$(CORE_SRCS))
.SECONDARY: $(FUZZ_LONG_OBJS)

$(FUZZ_LONG_OUT)/obj/%.o: c/%.c $(CORE_HDRS)
	@command -v $(FUZZ_CC) >/dev/null || { echo "fuzz: $(FUZZ_CC) not found; run 'make setup'" >&2; exit 1; }
	@mkdir -p $(FUZZ_LONG_OUT)/obj
	$(FUZZ_CC) $(subst -O1,,$(FUZZ_CORE_FLAGS)) $(FUZZ_LONG_XFLAGS) -Iinclude -c $< -o $@

$(FUZZ_LONG_OUT)/fuzz_%: fuzz/fuzz_%.c fuzz/fuzz.h $(FUZZ_LONG_OBJS)
	$(FUZZ_CC) $(subst -O1,,$(FUZZ_FLAGS)) $(FUZZ_LONG_XFLAGS) -Iinclude -Ifuzz $< $(FUZZ_LONG_OBJS) -o $@

fuzz-long: $(addprefix $(FUZZ_LONG_OUT)/fuzz_,$(FUZZ_LONG_NAMES))
	@set -e; for n in $(FUZZ_LONG_NAMES); do opts="-runs=$(FUZZ_RUNS) -max_total_time=$(FUZZ_LONG_SECONDS)"; \
	  pre="nice -n 19"; suf="-long"; $(subst $(FUZZ_OUT),$(FUZZ_LONG_OUT),$(FUZZ_RUN_ONE)); done
	@echo "fuzz-long: $(words $(FUZZ_LONG_NAMES)) harnesses, up to $(FUZZ_RUNS) runs each, no crash"

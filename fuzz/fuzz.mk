# fuzz/fuzz.mk -- included by the top Makefile (issue 11, item 1).
#
#   make fuzz        build every fuzz/fuzz_*.c with clang's libFuzzer + ASan + UBSan
#                    (UB fatal) and run each for FUZZ_SECONDS (default 20) from a
#                    copy of its seed corpus fuzz/corpus/NAME/; fails on any crash.
#   make fuzz-long   each harness for FUZZ_RUNS executions (default 10 M), one at a
#                    time at nice 19; logs and final stats in build/fuzz/NAME-long.log.
#   make fuzz-NAME   one harness, FUZZ_SECONDS.
# A crash leaves its input in build/fuzz/crash-NAME-*; replay it with
# build/fuzz/fuzz_NAME <file>. Adding a harness is adding fuzz/fuzz_NAME.c (and
# seeds in fuzz/corpus/NAME/): nothing to register.

FUZZ_CC      ?= clang
FUZZ_SECONDS ?= 20
FUZZ_RUNS    ?= 10000000
FUZZ_FLAGS   := -std=c99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
                -fno-omit-frame-pointer -Wall -Wextra -Werror -Wno-unused-function
FUZZ_OUT     := $(BUILD)/fuzz
FUZZ_SRCS    := $(sort $(wildcard fuzz/fuzz_*.c))
FUZZ_NAMES   := $(patsubst fuzz/fuzz_%.c,%,$(FUZZ_SRCS))
FUZZ_BINS    := $(addprefix $(FUZZ_OUT)/fuzz_,$(FUZZ_NAMES))
# -max_len: enough for a 48x48 raw frame and its arguments. -rss_limit_mb and
# -timeout make a leak or a hang a failure, not a stall.
FUZZ_OPTS    := -max_len=8192 -rss_limit_mb=2048 -timeout=20 -print_final_stats=1
FUZZ_ENV     := ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

.PHONY: fuzz fuzz-long fuzz-build $(addprefix fuzz-,$(FUZZ_NAMES))

$(FUZZ_OUT)/fuzz_%: fuzz/fuzz_%.c fuzz/fuzz.h $(CORE_SRCS) $(CORE_HDRS)
	@command -v $(FUZZ_CC) >/dev/null || { echo "fuzz: $(FUZZ_CC) not found; run 'make setup' (apt-get install clang libclang-rt-14-dev)" >&2; exit 1; }
	@mkdir -p $(FUZZ_OUT)
	$(FUZZ_CC) $(FUZZ_FLAGS) -Iinclude -Ifuzz $< $(CORE_SRCS) -o $@

fuzz-build: $(FUZZ_BINS)

# One harness: a scratch copy of the seeds (new inputs never touch the checked-in
# corpus), then libFuzzer for FUZZ_SECONDS; artifacts (crashes) in $(FUZZ_OUT).
define fuzz_one
	@rm -rf $(FUZZ_OUT)/work-$(1) && mkdir -p $(FUZZ_OUT)/work-$(1)
	@echo "== fuzz $(1): $(2) =="
	@cd $(FUZZ_OUT) && $(FUZZ_ENV) $(3) ./fuzz_$(1) $(FUZZ_OPTS) $(2) -artifact_prefix=crash-$(1)- \
	  work-$(1) $(CURDIR)/fuzz/corpus/$(1) > $(1)$(4).log 2>&1 || \
	  { tail -40 $(1)$(4).log; echo "fuzz $(1): FAILED (see $(FUZZ_OUT)/$(1)$(4).log)" >&2; exit 1; }
	@grep -E "stat::number_of_executed_units|Done [0-9]+ runs" $(FUZZ_OUT)/$(1)$(4).log | tr '\n' ' '; echo
endef

$(addprefix fuzz-,$(FUZZ_NAMES)): fuzz-%: $(FUZZ_OUT)/fuzz_%
	$(call fuzz_one,$*,-max_total_time=$(FUZZ_SECONDS),,)

fuzz: $(FUZZ_BINS)
	$(foreach n,$(FUZZ_NAMES),$(call fuzz_one,$(n),-max_total_time=$(FUZZ_SECONDS),,)
	)
	@echo "fuzz: $(words $(FUZZ_NAMES)) harnesses x $(FUZZ_SECONDS) s, no crash"

fuzz-long: $(FUZZ_BINS)
	$(foreach n,$(FUZZ_NAMES),$(call fuzz_one,$(n),-runs=$(FUZZ_RUNS),nice -n 19,-long)
	)
	@echo "fuzz-long: $(words $(FUZZ_NAMES)) harnesses x $(FUZZ_RUNS) runs, no crash"

# make bench -- C vs the float oracle per stage, plus callgrind instructions per pixel.
# Included by the top Makefile (it defines PY, CC, BUILD, STRICT, CORE_SRCS, CORE_HDRS,
# EXT_SUFFIX, PY_INC). Both the cffi extension timed here and the callgrind driver are
# built from the sources with the same flags, $(BENCH_OPT), into $(BUILD)/bench/, so
# the bench never depends on (or disturbs) an installed or -O1 check build.
#
#   make bench                      full run: bench/results.md and bench/results.json
#   make bench BENCH_ARGS=--quick   tiny frames, one repeat (seconds)
#   make bench BENCH_OPT=-O3        another optimisation level (meson release builds use -O3)
#   make ram-bill                   only the RAM bill: bench/ram_bill.md and bench/ram_bill.json

BENCH_DIR    := $(BUILD)/bench
BENCH_OPT    ?= -O2
BENCH_EXT    := $(BENCH_DIR)/_vtffi$(EXT_SUFFIX)
BENCH_DRIVER := $(BENCH_DIR)/callgrind_main
BENCH_ARGS   ?=
VALGRIND     ?= valgrind

$(BENCH_EXT): $(CORE_SRCS) $(CORE_HDRS) $(wildcard pyvehtrack/cdef/*.h) tools/build_ffi.py bench/bench.mk
	@mkdir -p $(BENCH_DIR)
	$(PY) tools/build_ffi.py $(BENCH_DIR)/_vtffi.c >/dev/null
	$(CC) -shared -fPIC $(BENCH_OPT) -Iinclude -I$(PY_INC) \
	  $(CORE_SRCS) $(BENCH_DIR)/_vtffi.c -o $@

# -g adds line info for callgrind_annotate only; it does not change the code generated.
# -z now resolves libc symbols (memset, ...) at start-up, so the first stage to call
# one is not charged the dynamic linker's lazy binding.
$(BENCH_DRIVER): bench/callgrind_main.c $(CORE_SRCS) $(CORE_HDRS) bench/bench.mk
	@mkdir -p $(BENCH_DIR)
	$(CC) $(STRICT) $(BENCH_OPT) -g -Wl,-z,now -Iinclude $(CORE_SRCS) bench/callgrind_main.c -o $@

bench: $(BENCH_EXT) $(BENCH_DRIVER) ram-bill
	PYTHONPATH=$(CURDIR) PYVEHTRACK_FFI=$(abspath $(BENCH_EXT)) $(PY) bench/bench.py \
	  --driver $(BENCH_DRIVER) --valgrind $(VALGRIND) --workdir $(BENCH_DIR) \
	  --cc "$(CC)" --cflags="$(BENCH_OPT)" --command "make bench" $(BENCH_ARGS)

# The RAM bill (issue 10): bench/ram_bill.c built once per configuration below,
# sizeof(vt_pipeline) and its parts, and one step on the largest bench frame each
# admits; bench/ram_bill.md and .json. Add a build: a name in RAM_NAMES and its
# RAM_DEFS_<name> (and a line in bench/ram_bill.py's NOTES).
RAM_NAMES        := default 720p vga vga-lean vga-lean-8
RAM_DEFS_default :=
RAM_DEFS_720p    := -DVT_MAX_WIDTH=1280 -DVT_MAX_HEIGHT=720
RAM_DEFS_vga     := -DVT_MAX_WIDTH=640 -DVT_MAX_HEIGHT=480
RAM_DEFS_vga-lean := $(RAM_DEFS_vga) -DVT_LANE_MAX_WORK_W=320 -DVT_LANE_MAX_WORK_H=240 \
                     -DVT_LANE_ACC_CELLS=16384 -DVT_KF_MAX_X=6 -DVT_KF_MAX_Z=3
RAM_DEFS_vga-lean-8 := $(RAM_DEFS_vga-lean) -DVT_MAX_TRACKS=8

$(BENCH_DIR)/ram_bill_%: bench/ram_bill.c $(CORE_SRCS) $(CORE_HDRS) bench/bench.mk
	@mkdir -p $(BENCH_DIR)
	$(CC) $(STRICT) -O1 $(RAM_DEFS_$*) -Iinclude $(CORE_SRCS) bench/ram_bill.c -o $@

.PHONY: ram-bill
ram-bill: $(addprefix $(BENCH_DIR)/ram_bill_,$(RAM_NAMES))
	$(PY) bench/ram_bill.py --workdir $(BENCH_DIR) $(RAM_NAMES)

# The classifier's costs (bench/classify_cost.c): instructions of vt_hog_prepare on a
# 1280x192 band, vt_hog_scan over it and vt_classify_box on one box; sizeof of the workspaces.
CLS_COST := $(BENCH_DIR)/classify_cost
$(CLS_COST): bench/classify_cost.c $(CORE_SRCS) $(CORE_HDRS) bench/bench.mk
	@mkdir -p $(BENCH_DIR)
	$(CC) $(STRICT) $(BENCH_OPT) -g -Iinclude $(CORE_SRCS) bench/classify_cost.c -o $@
.PHONY: classify-cost
classify-cost: $(CLS_COST)
	$(PY) -c "import cv2; cv2.imwrite('$(BENCH_DIR)/road_1280x720.pgm', cv2.imread('bench/data/road_1280x720.png', 0))"
	$(VALGRIND) --tool=callgrind --callgrind-out-file=$(BENCH_DIR)/classify.callgrind \
	  --toggle-collect='cost_*' $(CLS_COST) $(BENCH_DIR)/road_1280x720.pgm 1280 192
	callgrind_annotate --inclusive=yes $(BENCH_DIR)/classify.callgrind | grep -E 'cost_(hog|classify)' | grep -v '^ *\.'

# The block-scale TTC's cost per track and frame (bench/ttc_cost.c): one vt_ttc_step on the
# lead car of tests/data/kitti_clip (frames 5 -> 6, the tracker's boxes), default cfg with lag 1.
TTC_COST := $(BENCH_DIR)/ttc_cost
$(TTC_COST): bench/ttc_cost.c $(CORE_SRCS) $(CORE_HDRS) bench/bench.mk
	@mkdir -p $(BENCH_DIR)
	$(CC) $(STRICT) $(BENCH_OPT) -g -Iinclude $(CORE_SRCS) bench/ttc_cost.c -o $@
.PHONY: ttc-cost
ttc-cost: $(TTC_COST)
	$(PY) -c "import cv2; [cv2.imwrite('$(BENCH_DIR)/kclip_%d.pgm' % i, cv2.imread('tests/data/kitti_clip/00000%d.png' % i, 0)) for i in (5, 6)]"
	$(VALGRIND) --tool=callgrind --callgrind-out-file=$(BENCH_DIR)/ttc.callgrind \
	  --toggle-collect='cost_*' $(TTC_COST) $(BENCH_DIR)/kclip_5.pgm $(BENCH_DIR)/kclip_6.pgm \
	  255 35 401 181 257 34 405 182
	callgrind_annotate --inclusive=yes $(BENCH_DIR)/ttc.callgrind | grep -E 'cost_ttc' | grep -v '^ *\.'

# firmware_demo/firmware.mk -- included by the top Makefile.
#
#   make firmware       Cortex-M3 (soft-float ABI) and Cortex-M7 (FPv5, hard-float
#                       ABI) images of firmware_demo/ linking every c/*.c, their
#                       size table, and the forbidden-symbol check (no heap, no
#                       soft-float helper, no FP instruction); fails if it fails.
#   make firmware-run   the above, then both images under qemu-system-arm
#                       (mps2-an385 = Cortex-M3, mps2-an500 = Cortex-M7), printing
#                       their checksum lines (tests/test_firmware.py compares them
#                       with the host).
#
#   make firmware-caps  print the capacity flags the images are built with
#                       (FW_CAPS FW_DEFS): the host side of every comparison
#                       (tests/test_firmware.py's cffi build, the determinism
#                       matrix's host builds of main.c) is built with the same.
#
# The core is compiled with the same $(STRICT) flags as `make lib`, plus the
# target flags and FW_CAPS: the firmware's capacities, sized to the clip in flash
# (640x256), so every workspace of the full run -- the whole-road detector's, the
# overtaking stage's, the block TTC's and the vehicle model's -- fits beside the
# pipeline in the boards' 4 MB of RAM (at the library's default 1920x1080 the
# flow state alone is 1.9 MB and the model's 0.4 MB would not fit). Outputs go to
# $(BUILD)/firmware/. FW_DEFS adds further -D options for the firmware build only
# (e.g. FW_DEFS=-DVT_MAX_TRACKS=4); FW_CAPS= builds at the library's defaults.

FW_CC      ?= arm-none-eabi-gcc
FW_SIZE    ?= arm-none-eabi-size
FW_NM      ?= arm-none-eabi-nm
FW_OBJDUMP ?= arm-none-eabi-objdump
FW_QEMU    ?= qemu-system-arm
FW_TIMEOUT ?= 120
FW_CAPS    ?= -DVT_MAX_WIDTH=640 -DVT_MAX_HEIGHT=256
FW_DEFS    ?=

FW_OUT  := $(BUILD)/firmware
# The capacity flags are a dependency of the images: a change of FW_CAPS / FW_DEFS
# rebuilds them (and the host comparisons read the same flags: firmware-caps).
FW_FLAGS_STAMP := $(FW_OUT)/flags.txt
$(shell mkdir -p $(FW_OUT) && { echo '$(FW_CAPS) $(FW_DEFS)' | cmp -s - $(FW_FLAGS_STAMP) || \
  echo '$(FW_CAPS) $(FW_DEFS)' > $(FW_FLAGS_STAMP); })
FW_DEPS := $(CORE_SRCS) $(CORE_HDRS) $(wildcard firmware_demo/*.c firmware_demo/*.h) \
           firmware_demo/link.ld firmware_demo/firmware.mk $(FW_FLAGS_STAMP)
FW_OPT  := -O2 -g -ffunction-sections -fdata-sections

FW_ARCH_m3  := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
FW_ARCH_m7  := -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard
FW_CORE_m3  := cortex-m3
FW_CORE_m7  := cortex-m7
FW_BOARD_m3 := mps2-an385
FW_BOARD_m7 := mps2-an500

FW_SETUP_HINT := run 'make setup' (it apt-get installs gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)
fw_need = @for t in $(1); do command -v $$t >/dev/null 2>&1 || \
  { echo "firmware: $$t not found; $(FW_SETUP_HINT)" >&2; exit 1; }; done

.PHONY: firmware firmware-run firmware-caps

firmware-caps:
	@echo $(FW_CAPS) $(FW_DEFS)

# One image per core; % is m3 or m7. Everything is rebuilt when any source
# changes (a few files, a second or two).
$(FW_OUT)/firmware-%.elf: $(FW_DEPS)
	$(call fw_need,$(FW_CC))
	@rm -rf $(FW_OUT)/$* && mkdir -p $(FW_OUT)/$*
	@set -e; for f in $(CORE_SRCS); do \
	  $(FW_CC) $(STRICT) $(FW_OPT) $(FW_ARCH_$*) $(FW_CAPS) $(FW_DEFS) -Iinclude \
	    -c $$f -o $(FW_OUT)/$*/core_$$(basename $$f .c).o; done
	@$(FW_CC) $(STRICT) $(FW_OPT) $(FW_ARCH_$*) $(FW_CAPS) $(FW_DEFS) -Iinclude -Ifirmware_demo \
	  -DFW_CORE_NAME='"$(FW_CORE_$*)"' -c firmware_demo/main.c -o $(FW_OUT)/$*/main.o
	@$(FW_CC) $(STRICT) $(FW_OPT) $(FW_ARCH_$*) -ffreestanding -fno-tree-loop-distribute-patterns \
	  -Ifirmware_demo -c firmware_demo/board.c -o $(FW_OUT)/$*/board.o
	@$(FW_CC) $(FW_ARCH_$*) -nostdlib -nostartfiles -T firmware_demo/link.ld -Wl,--gc-sections \
	  -Wl,-Map=$(FW_OUT)/firmware-$*.map -o $@ $(FW_OUT)/$*/*.o -lgcc
	@echo "firmware: built $@ ($(FW_CORE_$*), $(words $(CORE_SRCS)) core sources, strict flags)"

firmware: $(FW_OUT)/firmware-m3.elf $(FW_OUT)/firmware-m7.elf
	$(call fw_need,$(FW_SIZE) $(FW_NM) $(FW_OBJDUMP))
	@echo "firmware size table (bytes; bss includes the .stack reserve, see below):"
	@$(FW_SIZE) $^
	@for c in m3 m7; do printf '  %s: ' $$c; $(FW_SIZE) -A $(FW_OUT)/firmware-$$c.elf | \
	  awk '$$1==".bss"{b=$$2} $$1==".stack"{s=$$2} END{printf ".bss %d (static buffers) + .stack %d (reserve)\n", b, s}'; done
	@FW_NM=$(FW_NM) FW_OBJDUMP=$(FW_OBJDUMP) sh firmware_demo/check_elf.sh \
	  $(FW_CORE_m3) $(FW_OUT)/firmware-m3.elf $(FW_OUT)/m3/*.o
	@FW_NM=$(FW_NM) FW_OBJDUMP=$(FW_OBJDUMP) sh firmware_demo/check_elf.sh \
	  $(FW_CORE_m7) $(FW_OUT)/firmware-m7.elf $(FW_OUT)/m7/*.o

# -icount shift=0: one instruction per virtual nanosecond, so the images' SysTick
# readings count instructions (the "insns" lines). Semihosting carries the output
# and the exit status; QEMU writes the semihosting console to stderr, so 2>&1
# keeps it in order with the section headers. `timeout` stops a hung image.
define fw_run
	@echo "== qemu $(FW_CORE_$(1)) $(FW_BOARD_$(1)) =="
	@timeout $(FW_TIMEOUT) $(FW_QEMU) -M $(FW_BOARD_$(1)) -nographic -monitor none \
	  -semihosting-config enable=on,target=native -icount shift=0 \
	  -kernel $(FW_OUT)/firmware-$(1).elf </dev/null 2>&1 || { rc=$$?; \
	  echo "firmware-run: the $(FW_CORE_$(1)) image failed under QEMU (exit $$rc; 124 = timed out after $(FW_TIMEOUT) s)" >&2; exit 1; }
endef

firmware-run: firmware
	$(call fw_need,$(FW_QEMU) timeout)
	$(call fw_run,m3)
	$(call fw_run,m7)

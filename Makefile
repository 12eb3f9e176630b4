# lodpipe - certified LOD chains for glTF 2.0.
#
#   make deps    install what is missing (Debian packages, npm test tools)
#   make         build build/lodpipe
#   make run     deps + build + the main job on the default scene (output in out/)
#   make test    deps + build + sanitizer build + every test
#   make bench   benchmarks into bench/RESULTS.md
#   make fuzz    libFuzzer harnesses (clang) for FUZZ_SECONDS each (tests/fuzz/)
#
# src/ is C11 and must build warning-free; third_party/ holds the thin C++17
# bridges to tinygltf, Draco (and later toml++).

CC      ?= cc
CXX     ?= g++
BUILD   := build
SHARED  ?= $(abspath ../shared)

# Libraries are checked with dpkg (libclang-rt-dev: libFuzzer's runtime for Debian's default
# clang, libclang-rt-14-dev on Debian 12, -19-dev on Debian 13); tools by their command, so
# a machine whose node or compiler came from elsewhere is not asked to install a conflicting
# package.
DEBIAN_PACKAGES := pkg-config libtinygltf-dev nlohmann-json3-dev libstb-dev libdraco-dev \
	libmeshoptimizer-dev libopenmesh-dev libtomlplusplus-dev libcgal-dev libclang-rt-dev exfatprogs exfat-fuse
DEBIAN_TOOLS := g++:g++ make:make python3:python3 node:nodejs npm:npm clang:clang strace:strace pgrep:procps

CPPFLAGS_COMMON := -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L -Isrc -Ithird_party -I$(BUILD)/gen
CFLAGS_COMMON   := -std=c11 -Wall -Wextra -Werror -pthread
CXXFLAGS_COMMON := -std=c++17 -Wall -Wextra -pthread -I/usr/include/draco -Wno-unused-parameter
LIBS            := -ldraco -lmeshoptimizer -ltomlplusplus -lm -pthread

OPT      := -O2 -g
SAN      := -O1 -g -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer

SRC_C    := $(sort $(wildcard src/*.c))
LIB_C    := $(filter-out src/main.c,$(SRC_C))
SRC_CXX  := $(sort $(wildcard third_party/*/*.cpp))
UNIT_SRC := $(sort $(wildcard tests/unit/test_*.c))

OBJ      := $(SRC_C:%.c=$(BUILD)/obj/%.o) $(SRC_CXX:%.cpp=$(BUILD)/obj/%.o)
LIB_OBJ_SAN := $(LIB_C:%.c=$(BUILD)/asan/obj/%.o) $(SRC_CXX:%.cpp=$(BUILD)/asan/obj/%.o)
OBJ_SAN  := $(BUILD)/asan/obj/src/main.o $(LIB_OBJ_SAN)
UNIT_BIN := $(UNIT_SRC:tests/unit/%.c=$(BUILD)/asan/%)

.PHONY: all deps run test unit asan clean bench hausdorff fuzz fuzz-build
all: $(BUILD)/lodpipe

# LODPIPE_SOURCE_ID: a hash of lodpipe's own source files, so that the batch cache
# (and --version) tell two builds apart that carry the same version number but
# would write different output. Regenerated whenever a source changes.
SOURCE_FILES := $(SRC_C) $(sort $(wildcard src/*.h)) $(SRC_CXX) $(sort $(wildcard third_party/*/*.h))
$(BUILD)/gen/source_id.h: $(SOURCE_FILES)
	@mkdir -p $(dir $@)
	@printf '#define LODPIPE_SOURCE_ID "%s"\n' "$$(cat $(SOURCE_FILES) | sha256sum | cut -c1-16)" > $@.tmp
	@mv $@.tmp $@
$(foreach o,src/batch.o src/main.o,$(BUILD)/obj/$(o) $(BUILD)/asan/obj/$(o) $(BUILD)/fuzz/obj/$(o)): $(BUILD)/gen/source_id.h

$(BUILD)/lodpipe: $(OBJ)
	$(CXX) -o $@ $^ $(LIBS)

$(BUILD)/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS_COMMON) $(CFLAGS_COMMON) $(OPT) -MMD -MP -c $< -o $@

$(BUILD)/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS_COMMON) $(CXXFLAGS_COMMON) $(OPT) -MMD -MP -c $< -o $@

# AddressSanitizer + UndefinedBehaviorSanitizer build: the tests run this one.
asan: $(BUILD)/asan/lodpipe $(UNIT_BIN)

$(BUILD)/asan/lodpipe: $(OBJ_SAN)
	$(CXX) $(SAN) -o $@ $^ $(LIBS)

$(BUILD)/asan/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS_COMMON) $(CFLAGS_COMMON) $(SAN) -MMD -MP -c $< -o $@

$(BUILD)/asan/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS_COMMON) $(CXXFLAGS_COMMON) $(SAN) -MMD -MP -c $< -o $@

$(BUILD)/asan/test_%: tests/unit/test_%.c $(LIB_OBJ_SAN)
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS_COMMON) $(CFLAGS_COMMON) $(SAN) -Itests/unit -o $@.o -c $<
	$(CXX) $(SAN) -o $@ $@.o $(LIB_OBJ_SAN) $(LIBS)

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)

# ---- dependencies ------------------------------------------------------------------
# Installs only what is missing, so it is a quick no-op on a prepared machine.
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
deps:
	@missing=""; for p in $(DEBIAN_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	for tp in $(DEBIAN_TOOLS); do command -v $${tp%%:*} >/dev/null 2>&1 || missing="$$missing $${tp##*:}"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing:$$missing"; \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get update -qq && \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing; \
	fi
	@$(MAKE) --no-print-directory tests/node_modules/.installed

tests/node_modules/.installed: tests/package.json tests/package-lock.json
	cd tests && npm ci --no-audit --no-fund --loglevel=error
	@touch $@

# ---- the main job on the default scene -------------------------------------------
run: deps
	$(MAKE) all
	@mkdir -p out
	$(BUILD)/lodpipe assets/default_scene.glb -o out/default_scene.glb --config pipeline.toml
	$(BUILD)/lodpipe inspect out/default_scene.glb
	@echo "wrote out/default_scene.glb"

# ---- tests -----------------------------------------------------------------------
# tests/oom.test.mjs preloads it to make one allocation fail (tests only).
$(BUILD)/failmalloc.so: tests/tools/failmalloc.c
	@mkdir -p $(dir $@)
	$(CC) -std=c11 -Wall -Wextra -Werror -O2 -g -shared -fPIC -o $@ $< -ldl

export ASAN_OPTIONS  := detect_leaks=1:abort_on_error=0:halt_on_error=1
export UBSAN_OPTIONS := halt_on_error=1:print_stacktrace=1

test: deps
	$(MAKE) all asan hausdorff $(BUILD)/mesh_check $(BUILD)/failmalloc.so fuzz-build
	LODPIPE_BIN=$(abspath $(BUILD)/asan/lodpipe) LODPIPE_BUILD=$(abspath $(BUILD)) \
	LODPIPE_SHARED=$(SHARED) node --test --test-concurrency=2 tests/
	rm -rf $(BUILD)/fuzz/test-corpus
	$(MAKE) --no-print-directory fuzz FUZZ_SECONDS=$(FUZZ_TEST_SECONDS) FUZZ_SEED=1 FUZZ_CORPUS=$(BUILD)/fuzz/test-corpus

# ---- fuzzing: libFuzzer harnesses (tests/fuzz/fuzz_*.c) --------------------------------
# The library is built a third time, with clang and -fsanitize=fuzzer-no-link,address,
# undefined, into build/fuzz/ (the C++ bridges with clang++). `make fuzz` runs every
# harness for FUZZ_SECONDS on its corpus build/fuzz/corpus/<name> (kept between runs),
# seeded from ../shared/assets, the degenerate-geometry files and tests/regressions/;
# make test starts from the seeds alone (FUZZ_CORPUS=build/fuzz/test-corpus, emptied).
# A crash leaves its input in build/fuzz/crashes/<name>/ and fails the target: copy it
# to tests/regressions/ with its expectation in tests/regressions/manifest.json.
FUZZ_CC      ?= clang
FUZZ_CXX     ?= clang++
FUZZ_SECONDS ?= 600
FUZZ_TEST_SECONDS ?= 30
FUZZ_SEED    ?= 0
FUZZ_CORPUS  ?= $(BUILD)/fuzz/corpus
FUZZ_SAN     := -O1 -g -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FUZZ_NAMES   := $(patsubst tests/fuzz/fuzz_%.c,%,$(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BIN     := $(FUZZ_NAMES:%=$(BUILD)/fuzz/fuzz_%)
FUZZ_LIB_OBJ := $(LIB_C:%.c=$(BUILD)/fuzz/obj/%.o) $(SRC_CXX:%.cpp=$(BUILD)/fuzz/obj/%.o)

fuzz-build: $(FUZZ_BIN)
# reached only through the pattern rule below: keep them, or make deletes them as intermediates
.SECONDARY: $(FUZZ_LIB_OBJ)

$(BUILD)/fuzz/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(CPPFLAGS_COMMON) $(CFLAGS_COMMON) $(FUZZ_SAN) -fsanitize=fuzzer-no-link -MMD -MP -c $< -o $@

$(BUILD)/fuzz/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(FUZZ_CXX) $(CPPFLAGS_COMMON) $(CXXFLAGS_COMMON) $(FUZZ_SAN) -fsanitize=fuzzer-no-link -MMD -MP -c $< -o $@

$(BUILD)/fuzz/fuzz_%: tests/fuzz/fuzz_%.c tests/fuzz/fuzz_common.h $(FUZZ_LIB_OBJ)
	$(FUZZ_CC) $(CPPFLAGS_COMMON) $(CFLAGS_COMMON) $(FUZZ_SAN) -fsanitize=fuzzer -Itests/fuzz -c $< -o $@.o
	$(FUZZ_CXX) $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $@.o $(FUZZ_LIB_OBJ) $(LIBS)

# -timeout: one input taking longer is a hang (a bug); -rss_limit_mb: so is runaway memory.
# 60 s: the slowest seed (suzanne, 968 triangles: the main job plus the harness's sampled
# measure, under the fuzzer's comparison tracing) takes 6.7 s alone here, and a mutation of it
# took over 20 s beside two other busy processes (2026-12-06), which is load, not a hang.
fuzz: fuzz-build
	@python3 tests/tools/make_degenerate.py $(BUILD)/fuzz/degenerate >/dev/null
	@python3 tests/fuzz/make_seeds.py $(SHARED)/assets $(BUILD)/fuzz/seeds $(BUILD)/fuzz/degenerate tests/regressions
	@set -e; for name in $(FUZZ_NAMES); do \
	  mkdir -p $(FUZZ_CORPUS)/$$name $(BUILD)/fuzz/crashes/$$name; \
	  echo "fuzz_$$name: $(FUZZ_SECONDS) s"; \
	  nice $(BUILD)/fuzz/fuzz_$$name -max_total_time=$(FUZZ_SECONDS) -seed=$(FUZZ_SEED) -max_len=65536 \
	    -timeout=60 -rss_limit_mb=2048 -print_final_stats=1 \
	    -artifact_prefix=$(BUILD)/fuzz/crashes/$$name/ \
	    $(FUZZ_CORPUS)/$$name $(BUILD)/fuzz/seeds/$$name 2>$(BUILD)/fuzz/fuzz_$$name.log \
	  || { tail -n 60 $(BUILD)/fuzz/fuzz_$$name.log; exit 1; }; \
	  grep -E "^#[0-9]+[[:space:]]+DONE|stat::number_of_executed_units|stat::peak_rss_mb" $(BUILD)/fuzz/fuzz_$$name.log | tr '\n' ' '; echo; \
	done

# ---- benchmarks: quality and speed against meshoptimizer, into bench/RESULTS.md --------
# Measurements, not tests (27 to 75 minutes on the 2-core hosts seen: run.py's quality part
# is most of it; batch.py, draco.py and morph.py take a few minutes each).
bench: deps
	$(MAKE) all hausdorff
	@command -v python3 >/dev/null && python3 -c 'import numpy' 2>/dev/null || \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends python3-numpy
	python3 bench/run.py
	python3 bench/batch.py
	python3 bench/draco.py
	python3 bench/morph.py

# The independent topology oracle (OpenMesh), used by tests/simplify.test.mjs.
$(BUILD)/mesh_check: tests/tools/mesh_check.cpp
	@mkdir -p $(BUILD)
	$(CXX) -std=c++17 -O2 $< -lOpenMeshCore -o $@

# The independent Hausdorff measure (../shared/tools/hausdorff, CGAL), built from a
# copy so the shared folder stays read-only.
hausdorff: $(BUILD)/hausdorff/hausdorff
$(BUILD)/hausdorff/hausdorff: $(wildcard $(SHARED)/tools/hausdorff/*)
	@mkdir -p $(BUILD)/hausdorff
	cp $(SHARED)/tools/hausdorff/* $(BUILD)/hausdorff/
	$(MAKE) -C $(BUILD)/hausdorff

clean:
	rm -rf $(BUILD) out

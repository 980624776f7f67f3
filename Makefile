# refrender build. `make` builds build/refrender; `make demo` installs missing
# Debian packages, builds and renders the default scene; `make test` runs the
# C unit tests and the pytest suite, built with RR_DCHECK invariant checks on
# in build-check/. `make SAN=1 test` does the same with AddressSanitizer and
# UBSan in build-san/.

CC      ?= cc
CXX     ?= c++
PYTHON  := /usr/bin/python3
SAN     ?= 0
DCHECKS ?= 0

ifeq ($(SAN),1)
BUILD   := build-san
OPT     := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined -DRR_DCHECKS
SANLD   := -fsanitize=address,undefined
else ifeq ($(DCHECKS),1)
BUILD   := build-check
OPT     := -O2 -g -DRR_DCHECKS
SANLD   :=
else
BUILD   := build
OPT     := -O2 -g
SANLD   :=
endif

# The user's CFLAGS/CXXFLAGS/CPPFLAGS come last (make CFLAGS=-O0 still
# builds); -MMD -MP track header dependencies.
INCLUDES  := -I/usr/include/embree3 -I/usr/include/OpenEXR -I/usr/include/libxml2
RR_CPPFLAGS = -D_GNU_SOURCE -Isrc $(INCLUDES) $(BUILD_ID_FLAG) \
              -DRR_SOURCE_DIR='"$(CURDIR)"' -MMD -MP $(CPPFLAGS)
# -ffp-contract=off: the Gaussian kernels in AVX2 lanes (src/core/lanes.h) give
# the scalar path's answers bit for bit only if neither is fused into FMA (-std=c11
# implies it for GCC; clang, or -std=gnu11 with -march=native, would fuse)
# -fPIC: one set of objects makes both refrender and librefrender.so (the
# Python package's library), so both render with the very same code;
# -fno-semantic-interposition lets a file's calls to its own functions be
# inlined as without -fPIC (the library exports only its API: refrender_api.map)
RR_CFLAGS   = -std=c11 -ffp-contract=off -fPIC -fno-semantic-interposition $(OPT) -Wall -Wextra $(CFLAGS)
RR_CXXFLAGS = -std=c++17 $(OPT) -Wall -Wextra $(CXXFLAGS)
LDLIBS   := -ljson-c -lassimp -lembree3 -lOpenEXRCore -lxml2 -lpng -ldl -lpthread -lm
# OpenImageIO only in the preview module, opened when a preview is written
# (src/io/preview.h): linked into refrender it cost every run 0.4 s of loading
PREVIEW_LIBS := -lOpenImageIO -lOpenImageIO_Util

LIB_SRCS := core/common core/arena core/lanes core/inputfile core/atomicfile surfels/kbuffer surfels/splat \
            surfels/pointmodel formats/ply gaussians/gaussian formats/gaussian_ply gaussians/gaussian_dynamic gaussians/gaussian_stg gaussians/gaussian_fdgs \
            formats/gaussian_ply_common formats/gaussian_dynamic_ply formats/gaussian_stg_ply formats/gaussian_fdgs_ply gaussians/gaussian_hit gaussians/gaussian_raster_rules gaussians/gaussian_hit_2d gaussians/gaussian_hit_3d \
            gaussians/gaussian_cull gaussians/gaussian_reach gaussians/gaussian_blend formats/camjson formats/colmap formats/llff formats/camsource formats/transforms \
            surfels/shapes surfels/surfelize formats/meshload core/rotation motion/curve motion/trajectory formats/tum \
            motion/animation formats/animfile core/camera motion/shutter render/sampler scene/scene io/preview io/preview_png \
            scenexml/scene_xml scenexml/scene_xml_util scenexml/scene_xml_anim scenexml/scene_xml_camera scenexml/scene_params accel/accel \
            accel/accel_build accel/accel_collide render/gaussian_integrator render/exact render/exact_kinds \
            render/exact_integrate render/integrator render/surfel_integrator scene/shade render/film render/noise render/render render/render_settings splatting/splat_settings splatting/frame splatting/splatting splatting/volumetric splatting/guan_mueller formats/exr io/output io/render_attrs \
            cmd/cli
LIB_OBJS := $(LIB_SRCS:%=$(BUILD)/%.o)
PREVIEW_SO := $(BUILD)/refrender-preview.so
APP_OBJS := $(BUILD)/cmd/main.o $(BUILD)/cmd/render_cmd.o $(BUILD)/cmd/render_frames.o $(BUILD)/cmd/gen_cmd.o $(BUILD)/cmd/surfel_output.o $(BUILD)/cmd/merge_cmd.o $(BUILD)/cmd/surfels_cmd.o \
            $(BUILD)/cmd/export_cmd.o $(BUILD)/cmd/splat_cmd.o $(BUILD)/cmd/noise_report.o $(BUILD)/cmd/dataset_cmd.o
TEST_SRCS := $(wildcard tests/test_*.c)
TEST_OBJS := $(TEST_SRCS:tests/%.c=$(BUILD)/tests/%.o) $(BUILD)/tests/harness.o $(BUILD)/tests/gaussian_test_util.o \
            $(BUILD)/tests/gaussian_hit_util.o

# the libFuzzer targets (tests/fuzz/fuzz_NAME.c); `make test` replays their corpora (below)
FUZZ_TARGETS := scene ply anim state gaussian camjson render_gaussian render_camjson tum transforms colmap llff
REPLAY_DIR     := $(BUILD)/replay
REPLAY_TARGETS := $(FUZZ_TARGETS:%=$(REPLAY_DIR)/replay_%)
REPLAY_OBJS    := $(FUZZ_TARGETS:%=$(BUILD)/tests/fuzz/fuzz_%.o) $(BUILD)/tests/fuzz/render_check.o \
                  $(BUILD)/tests/fuzz/replay_main.o

BIN      := $(BUILD)/refrender
# refrender as a C library (src/api/refrender_api.h) for the Python package
# (python/, `make python`): the render command's objects and the API
LIB_SO   := $(BUILD)/librefrender.so
TESTBIN  := $(BUILD)/unit_tests

.PHONY: all python deps demo test test-build test-c test-py test-cluster test-fuzz fuzz bench bench-time bench-samplers scale-models thesis-table clean clean-models scenes references gallery
all: $(BIN) $(BUILD)/refrender-bench $(LIB_SO)
python: $(LIB_SO)

# An object without its .d file (built before dependency tracking, or the
# .d was lost) depends on a missing file and is rebuilt; objects are touched
# after compiling because clang writes the .d after the object.
$(BUILD)/%.o: src/%.c $(BUILD)/%.d $(BUILD)/cflags | $(BUILD)
	@mkdir -p $(@D)
	$(CC) $(RR_CPPFLAGS) $(RR_CFLAGS) -c $< -o $@
	@touch $@
$(BUILD)/cmd/%.o: src/cmd/%.c $(BUILD)/cmd/%.d $(BUILD)/cflags | $(BUILD)
	@mkdir -p $(@D)
	$(CC) $(RR_CPPFLAGS) $(RR_CFLAGS) -Isrc -c $< -o $@
	@touch $@
$(PREVIEW_SO): src/io/preview.cpp $(BUILD)/io/preview-so.d | $(BUILD)
	@mkdir -p $(BUILD)/io
	$(CXX) $(RR_CPPFLAGS) $(RR_CXXFLAGS) -MF $(BUILD)/io/preview-so.d -fPIC -shared $< -o $@ $(SANLD) $(PREVIEW_LIBS)
# The build's identity (refrender:build, part of a render's identity: a
# state from another build is not merged or resumed): the SHA-256 of the
# code under src/ ("sha256sum FILE" lines in C-locale path order), of the
# compiler (its --version line), its flags and the Embree and TBB versions
# compiled against (their headers' version macros), hashed again: each can
# change a render's bits (issue 56.9). Paths and contents only, no times
# nor the build directory, so the same sources and toolchain give the same
# id in every build directory. The recipe runs at each make (flags are no
# file); the id file is replaced only when the id changes (rebuilding
# nothing otherwise), and only render_attrs.o is compiled with it
# (-DRR_BUILD_ID). `make print-build-id` prints the id without writing it.
BUILD_ID_SRCS := $(sort $(wildcard src/*/*.c src/*/*.h src/*/*.cpp))
BUILD_ID_VERSIONS := '\#include <embree3/rtcore_config.h>\n\#include <oneapi/tbb/version.h>\nembree RTC_VERSION_STRING tbb TBB_VERSION_STRING\n'
# $(call build_id_text,COMPILER,FLAGS): the id on stdout
define build_id_text
v=$$(printf $(BUILD_ID_VERSIONS) | $(CXX) -E -P -x c++ $(INCLUDES) - | tail -n1) && \
  case "$$v" in 'embree "'*'" tbb "'*) ;; *) echo "build id: no Embree/TBB version in their headers" >&2; exit 1;; esac && \
  c=$$($(1) --version | head -n1) && test -n "$$c" && \
  { (cd src && LC_ALL=C sha256sum $(BUILD_ID_SRCS:src/%=%)) && echo "$$c" && echo 'flags: $(strip $(2))' && \
    echo "$$v"; } | sha256sum | cut -d' ' -f1
endef
define build_id_file
@mkdir -p $(@D)
@$(call build_id_text,$(1),$(2)) > $@.tmp && test -s $@.tmp && \
    { cmp -s $@.tmp $@ && rm -f $@.tmp || mv -f $@.tmp $@; }
endef
BUILD_ID_FLAG :=
.PHONY: build-id-always print-build-id
$(BUILD)/build_id: $(BUILD_ID_SRCS) build-id-always
	$(call build_id_file,$(CC),$(RR_CFLAGS) $(CPPFLAGS))
print-build-id:
	@$(call build_id_text,$(CC),$(RR_CFLAGS) $(CPPFLAGS))
$(BUILD)/io/render_attrs.o: $(BUILD)/build_id
# The compile flags as a file, replaced only when they change; the objects
# depend on it, so a build directory made before a change of flags (-fPIC,
# which librefrender.so needs) is recompiled, not linked stale
$(BUILD)/cflags: build-id-always
	@mkdir -p $(@D)
	@echo '$(RR_CFLAGS) $(CPPFLAGS)' > $@.tmp && { cmp -s $@.tmp $@ && rm -f $@.tmp || mv -f $@.tmp $@; }
$(BUILD)/io/render_attrs.o: BUILD_ID_FLAG = -DRR_BUILD_ID='"$(file <$(BUILD)/build_id)"'
$(BUILD)/tests/%.o: tests/%.c $(BUILD)/tests/%.d $(BUILD)/cflags | $(BUILD)
	@mkdir -p $(@D)
	$(CC) $(RR_CPPFLAGS) $(RR_CFLAGS) -Isrc -c $< -o $@
	@touch $@
DEPFILES := $(LIB_OBJS:.o=.d) $(APP_OBJS:.o=.d) $(BUILD)/api/refrender_api.d $(TEST_OBJS:.o=.d) $(BUILD)/bench/bench.d $(BUILD)/bench/bench_gaussian.d $(BUILD)/bench/bench_splat.d \
            $(BUILD)/io/preview-so.d $(REPLAY_OBJS:.o=.d) $(BUILD)/replay/scene_xml.d
$(DEPFILES):
-include $(wildcard $(DEPFILES))
$(BUILD):
	mkdir -p $(BUILD)/tests/fuzz $(BUILD)/cmd $(BUILD)/replay

$(BIN): $(APP_OBJS) $(LIB_OBJS) | $(PREVIEW_SO)
	$(CC) $(SANLD) -o $@ $^ $(LDLIBS)
# -Bsymbolic: the library's calls stay inside it, whatever the host process defines
$(LIB_SO): $(BUILD)/api/refrender_api.o $(APP_OBJS) $(LIB_OBJS) src/api/refrender_api.map
	$(CC) $(SANLD) -shared -Wl,-Bsymbolic -Wl,--version-script=src/api/refrender_api.map -o $@ $(filter %.o,$^) $(LDLIBS)
$(TESTBIN): $(TEST_OBJS) $(LIB_OBJS)
	$(CC) $(SANLD) -o $@ $^ $(LDLIBS)
$(BUILD)/refrender-bench: $(BUILD)/bench/bench.o $(BUILD)/bench/bench_gaussian.o $(BUILD)/bench/bench_splat.o $(LIB_OBJS)
	$(CC) $(SANLD) -o $@ $^ $(LDLIBS)

deps:
	scripts/install-deps.sh

demo: deps
	$(MAKE) $(BIN)
	mkdir -p out
	$(BIN) scenes/default.xml -o out/demo.exr --preview out/demo.png

# (the plain build's test targets run in build-check/: below)
ifneq ($(SAN)$(DCHECKS),00)
test-c: $(TESTBIN)
	$(TESTBIN)
endif

# LD_PRELOAD shim that fails the Nth write or rename (tests/test_faults.py);
# under SAN=1 without its malloc (ASan's own must stay: faultinject.c)
SHIM_FLAGS := $(if $(filter 1,$(SAN)),-DFAULTINJECT_NO_MALLOC)
$(BUILD)/libfaultinject.so: tests/faultinject.c | $(BUILD)
	$(CC) -O1 -g -Wall -Wextra $(SHIM_FLAGS) -shared -fPIC $< -o $@ -ldl

# pytest-xdist workers (python3-pytest-xdist): the suite's renders are
# single processes, so one worker a core halves its time on 2 cores
TEST_JOBS ?= $(shell nproc)
# (the C unit tests and the corpus replays run as pytest items too:
# tests/test_unit_tests.py)
test-py: $(BIN) $(TESTBIN) $(BUILD)/refrender-bench $(BUILD)/libfaultinject.so $(LIB_SO) $(REPLAY_TARGETS) scenes
	REFRENDER=$(CURDIR)/$(BIN) UNIT_TESTS=$(CURDIR)/$(TESTBIN) FAULTINJECT=$(CURDIR)/$(BUILD)/libfaultinject.so \
	    REFRENDER_LIB=$(CURDIR)/$(LIB_SO) FUZZ_REPLAY_DIR=$(CURDIR)/$(REPLAY_DIR) \
	    $(PYTHON) -m pytest -q -n $(TEST_JOBS) tests

# A real Slurm (scripts/README.md, "Rendering on a Slurm cluster"): tests/cluster_slurm.py
# starts a throwaway single-node cluster of its own (Debian's slurm-wlm and
# munge: scripts/install-deps.sh --cluster) and renders through
# scripts/slurm-render.sbatch with the plain build, as users run it. Not
# part of `make test`; about a minute.
test-cluster:
	$(MAKE) SAN=0 DCHECKS=0 build/refrender
	$(PYTHON) -m pytest -q -rs -p no:xdist tests/cluster_slurm.py

# Tests run with the RR_DCHECK invariant checks on (src/core/common.h): the plain
# build stays the one users run, without them.
ifeq ($(SAN)$(DCHECKS),00)
test test-c test-fuzz:
	$(MAKE) DCHECKS=1 $@
else
# Everything is built first, a job a core, then pytest runs every test (the
# C unit tests and the fuzz corpora's replays among its items: pytest's
# workers share them out with the rest).
test:
	$(MAKE) -j$(TEST_JOBS) test-build
	$(MAKE) test-py
endif

# Fuzz targets (tests/fuzz/): libFuzzer with ASan + UBSan, built with clang
# in build-fuzz/ by `make fuzz FUZZ_SECONDS=N`, which fuzzes each target for
# N seconds, keeping what it finds in build-fuzz/corpus/. `make test` replays
# each committed corpus through its own build instead (REPLAY_TARGETS above;
# with ASan + UBSan under SAN=1, as .ci/run also does).
FUZZ_SECONDS ?= 60
FUZZ_DIR     := build-fuzz
FUZZ_FLAGS   := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined
FUZZ_CFLAGS  := -std=c11 -ffp-contract=off -D_GNU_SOURCE -DRR_DCHECKS $(FUZZ_FLAGS) -fsanitize=fuzzer-no-link -Wall -Wextra -Isrc $(INCLUDES) \
                -DSCENE_MAX_GENERATED=1e4
FUZZ_OBJS    := $(LIB_SRCS:%=$(FUZZ_DIR)/%.o)

$(FUZZ_DIR)/%.o: src/%.c $(FUZZ_DIR)/%.d
	@mkdir -p $(@D)
	clang $(FUZZ_CFLAGS) $(BUILD_ID_FLAG) -MMD -MP -c $< -o $@
	@touch $@
$(FUZZ_DIR)/fuzz_%.o: tests/fuzz/fuzz_%.c $(FUZZ_DIR)/fuzz_%.d
	@mkdir -p $(FUZZ_DIR)
	clang $(FUZZ_CFLAGS) -MMD -MP -Isrc -c $< -o $@
	@touch $@
# the rendering targets' shared harness (tests/fuzz/render_check.h)
$(FUZZ_DIR)/render_check.o: tests/fuzz/render_check.c $(FUZZ_DIR)/render_check.d
	@mkdir -p $(FUZZ_DIR)
	clang $(FUZZ_CFLAGS) -MMD -MP -Isrc -c $< -o $@
	@touch $@
$(FUZZ_DIR)/build_id: $(BUILD_ID_SRCS) build-id-always
	$(call build_id_file,clang,$(FUZZ_CFLAGS))
$(FUZZ_DIR)/io/render_attrs.o: $(FUZZ_DIR)/build_id
$(FUZZ_DIR)/io/render_attrs.o: BUILD_ID_FLAG = -DRR_BUILD_ID='"$(file <$(FUZZ_DIR)/build_id)"'
FUZZ_DEPS := $(FUZZ_OBJS:.o=.d) $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%.d) $(FUZZ_DIR)/render_check.d
$(FUZZ_DEPS):
-include $(wildcard $(FUZZ_DEPS))
$(FUZZ_DIR)/fuzz_%: $(FUZZ_DIR)/fuzz_%.o $(FUZZ_DIR)/render_check.o $(FUZZ_OBJS)
	clang++ $(FUZZ_FLAGS) -fsanitize=fuzzer $^ -o $@ $(LDLIBS)
.SECONDARY: $(FUZZ_OBJS) $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%.o) $(FUZZ_DIR)/render_check.o

# `make test` replays each target's corpus through tests/fuzz/replay_main.c
# linked with this build's objects (RR_DCHECK on; under SAN=1 ASan and
# UBSan, as build-fuzz/), not through build-fuzz/'s targets: a second,
# clang-instrumented build of the whole source was a third of a fresh
# clone's `make test` build. scene_xml.c is compiled again with the fuzz
# builds' cap on generated surfels (the corpora were found under it).
$(REPLAY_DIR)/scene_xml.o: src/scenexml/scene_xml.c $(REPLAY_DIR)/scene_xml.d $(BUILD)/cflags | $(BUILD)
	@mkdir -p $(@D)
	$(CC) $(RR_CPPFLAGS) $(RR_CFLAGS) -DSCENE_MAX_GENERATED=1e4 -c $< -o $@
	@touch $@
$(REPLAY_DIR)/replay_%: $(BUILD)/tests/fuzz/fuzz_%.o $(BUILD)/tests/fuzz/render_check.o $(BUILD)/tests/fuzz/replay_main.o \
                       $(REPLAY_DIR)/scene_xml.o $(filter-out $(BUILD)/scenexml/scene_xml.o,$(LIB_OBJS))
	$(CC) $(SANLD) -o $@ $^ $(LDLIBS)
.SECONDARY: $(REPLAY_OBJS)

test-build: $(BIN) $(TESTBIN) $(BUILD)/refrender-bench $(BUILD)/libfaultinject.so $(LIB_SO) $(REPLAY_TARGETS) scenes
ifneq ($(SAN)$(DCHECKS),00)
test-fuzz: $(REPLAY_TARGETS)
	for t in $(FUZZ_TARGETS); do \
	    $(REPLAY_DIR)/replay_$$t tests/fuzz/corpus/$$t 2>$(REPLAY_DIR)/replay_$$t.log \
	        || { tail -40 $(REPLAY_DIR)/replay_$$t.log; exit 1; }; \
	done
endif

fuzz: $(FUZZ_TARGETS:%=$(FUZZ_DIR)/fuzz_%)
	failed=""; for t in $(FUZZ_TARGETS); do \
	    mkdir -p $(FUZZ_DIR)/corpus/$$t $(FUZZ_DIR)/crashes/$$t; \
	    $(FUZZ_DIR)/fuzz_$$t $(FUZZ_DIR)/corpus/$$t tests/fuzz/corpus/$$t -dict=tests/fuzz/$$t.dict \
	        -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=8192 -timeout=10 -print_final_stats=1 \
	        -artifact_prefix=$(FUZZ_DIR)/crashes/$$t/ || failed="$$failed $$t"; \
	done; \
	[ -z "$$failed" ] || { echo "fuzz: findings in$$failed (inputs in $(FUZZ_DIR)/crashes/)"; exit 1; }

# Speed and memory against Embree's built-in disc primitive, measured in the
# same run (a benchmark, not a test). BENCH_ARGS=quick for a short smoke run,
# BENCH_ARGS="full SERIES" for one series (see src/bench/BENCH.md).
bench: $(BUILD)/refrender-bench
	mkdir -p out
	$(BUILD)/refrender-bench out/bench.csv $(BENCH_ARGS)
	@if [ "$(BENCH_ARGS)" != quick ]; then $(MAKE) --no-print-directory bench-time bench-samplers; fi

# Time to equal error, --time-integration exact against sampled time
# (src/EXACT.md); part of `make bench` except in quick mode.
TTE_SCENES ?= default,diagonal,rotation,towards_camera,crossing,camera_pan,large
bench-time: $(BIN) scenes
	$(PYTHON) scripts/time_to_error.py --scenes $(TTE_SCENES) --out out/time_to_error

# Wolf 2008's Table 5.1 as an error table (src/SPLAT.md): the splatting
# methods against a converged ground truth; regenerates the committed
# reference_images/thesis/thesis_table.{csv,tex,png}.
thesis-table: $(BIN) scenes
	$(PYTHON) scripts/thesis_table.py --out reference_images/thesis --refrender $(BIN)

# The samplers' convergence on the suite's, the Gaussian examples' and the
# benchmark-scale view, and the time to 1, 0.1 and 0.01 of an 8-bit level on
# the benchmark-scale view (scripts/sampler_study.py; src/bench/BENCH.md).
# Part of `make bench` except in quick mode.
bench-samplers: $(BIN) scenes scale-models
	$(PYTHON) scripts/sampler_study.py convergence --out out/samplers
	$(PYTHON) scripts/sampler_study.py time-to-error --out out/samplers

# scenes/bench/scale.xml's models: refrender-bench's scale row as files
# (three 2DGS spheres of 1M Gaussians, SH degree 3; 730 MB, not committed)
SCALE_RADII := 1 0.75 0.5
scale-models: $(BIN)
	mkdir -p scenes/models
	i=0; for r in $(SCALE_RADII); do f=scenes/models/scale_layer$$i.ply; \
	    [ -s $$f ] || $(BIN) gen sphere --gaussians 2dgs --sh-degree 3 --count 1000000 --radius $$r -o $$f || exit 1; \
	    i=$$((i + 1)); done

# The scene suite (scenes/*.xml; README "Scene suite"). Scanned models come
# from Debian packages and are converted into scenes/models/ (not committed).
SUITE    := sphere_weights_box sphere_weights_linear sphere_weights_exp diagonal rotation \
            towards_camera crossing thin_fast camera_pan large
REF_ARGS := --spp 4 --tspp 32 --batches 16 --seed 1

scenes: $(BIN)
	REFRENDER=$(BIN) scripts/fetch-models.sh

references: scenes
	for s in $(SUITE); do $(BIN) scenes/$$s.xml $(REF_ARGS) -o reference_images/$$s.exr --quiet || exit 1; done
	$(PYTHON) scripts/gallery.py reference_images/gallery.png $(SUITE:%=reference_images/%.exr)

gallery: scenes
	mkdir -p out/gallery
	for s in $(SUITE); do $(BIN) scenes/$$s.xml --spp 4 --tspp 16 -o out/gallery/$$s.exr --quiet || exit 1; done
	$(PYTHON) scripts/gallery.py out/gallery.png $(SUITE:%=out/gallery/%.exr)

# Keeps scenes/models/ (converted scanned models and their download):
# 'make clean-models' removes them, and the next 'make scenes' fetches again.
clean:
	rm -rf build build-san build-fuzz out
clean-models:
	rm -rf scenes/models

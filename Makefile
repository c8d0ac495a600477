# mosyn: the two commands a new user needs.
#   make demo   install what is missing, build the command line, run the main job (README.md)
#   make test   install what is missing, build, run the tests
# Anything else here is a building block of those two.

BUILD   ?= build
JOBS    ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=
DATA_DIR ?= $(CURDIR)/../shared/data
CACHE   ?= $(BUILD)/cache

DEB_PACKAGES := build-essential cmake pkg-config libtorch-dev libopenblas0-openmp libeigen3-dev \
  libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev libzip-dev \
  libpng-dev libgif-dev libstb-dev libtinygltf-dev libwebsocketpp-dev libboost-dev libceres-dev libgloo-dev \
  python3-numpy
# Tools checked by command, not package: a machine may have them from elsewhere (e.g. nodejs
# with its own npm), and installing Debian's package over that would conflict.
DEB_TOOLS := npm:npm chromium:chromium

# make test SANITIZE=1: the same suite built with AddressSanitizer + UndefinedBehaviorSanitizer in
# its own build dir; LibTorch's own leaks are suppressed by sanitizers/lsan.supp (nothing of ours).
ifeq ($(SANITIZE),1)
BUILD := build-asan
CMAKE_FLAGS += -DMOSYN_SANITIZE=ON -DMOSYN_BUILD_BENCH=OFF "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -g1 -DNDEBUG"
export ASAN_OPTIONS := detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=0
export LSAN_OPTIONS := suppressions=$(CURDIR)/sanitizers/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS := print_stacktrace=1:halt_on_error=1:suppressions=$(CURDIR)/sanitizers/ubsan.supp
endif

# make fuzz: libFuzzer harnesses (fuzz/) built by clang in build-fuzz, each run FUZZ_SECONDS on a
# working copy of its seed corpus (fuzz/corpus/<target>/ stays as committed); crashes land in
# build-fuzz/artifacts/<target>/. `make test` only replays the seed corpora (ctest fuzz.*).
FUZZ_SECONDS ?= 600
FUZZ_TARGETS ?= bvh npy csv json_config dataset run
FUZZ_DEB_PACKAGES := clang-14
FUZZ_BUILD := build-fuzz

.PHONY: demo test deps configure build clean fuzz

deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	for t in $(DEB_TOOLS); do \
	  command -v $${t%%:*} >/dev/null 2>&1 || missing="$$missing $${t#*:}"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) > /dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The demo builds only what it runs (the command-line programs), not the tests, and says how long
# each stage took.
demo: configure
	@start=$$(date +%s); cmake --build $(BUILD) -j $(JOBS) --target mosyn mosyn-torch; \
	  echo "demo: built the command line in $$(( $$(date +%s) - start )) s"
	@bash scripts/demo.sh $(BUILD) $(DATA_DIR) $(CACHE)

clean:
	rm -rf $(BUILD)

fuzz: deps
	@command -v clang++-14 >/dev/null 2>&1 || { if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $(FUZZ_DEB_PACKAGES); }
	@CC=clang-14 CXX=clang++-14 cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -g -DNDEBUG" \
	  -DMOSYN_FUZZ=ON -DMOSYN_BUILD_TESTS=OFF -DMOSYN_BUILD_BENCH=OFF > /dev/null
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target $(addprefix fuzz_,$(FUZZ_TARGETS))
	@for t in $(FUZZ_TARGETS); do \
	  mkdir -p $(FUZZ_BUILD)/corpus/$$t $(FUZZ_BUILD)/artifacts/$$t; \
	  echo "fuzz_$$t: $(FUZZ_SECONDS) s"; \
	  $(FUZZ_BUILD)/fuzz/fuzz_$$t -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
	    -artifact_prefix=$(FUZZ_BUILD)/artifacts/$$t/ $(FUZZ_BUILD)/corpus/$$t fuzz/corpus/$$t > $(FUZZ_BUILD)/fuzz_$$t.log 2>&1; \
	  rc=$$?; tail -n 12 $(FUZZ_BUILD)/fuzz_$$t.log; [ $$rc = 0 ] || exit $$rc; \
	done

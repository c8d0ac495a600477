# mosyn: the two commands a new user needs.
#   make demo   install what is missing, build, run the main job
#   make test   install what is missing, build, run the tests
# Anything else here is a building block of those two.

BUILD   ?= build
JOBS    ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=
DATA_DIR ?= $(CURDIR)/../shared/data
CACHE   ?= $(BUILD)/cache

DEB_PACKAGES := build-essential cmake pkg-config libtorch-dev libopenblas0-openmp libeigen3-dev \
  libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev libzip-dev \
  libpng-dev libgif-dev libstb-dev libtinygltf-dev
# Tools checked by command, not package: a machine may have them from elsewhere (e.g. nodejs
# with its own npm), and installing Debian's package over that would conflict.
DEB_TOOLS := npm:npm chromium:chromium

.PHONY: demo test deps configure build clean

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

demo: build
	@bash scripts/demo.sh $(BUILD) $(DATA_DIR) $(CACHE)

clean:
	rm -rf $(BUILD)

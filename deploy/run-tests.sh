#!/usr/bin/env bash
# Installs the dependencies, then builds and runs every unit test twice: in the `dev` build
# and in the `asan` build (AddressSanitizer + UndefinedBehaviorSanitizer). Fails on any failure.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
deploy/install-deps.sh
if [[ ! -d ../shared/data/cases ]]; then
  echo "run-tests: ../shared/data/cases is missing (the shared hole cases live beside this checkout)" >&2
  exit 1
fi
# The fault-injection integration tests (strace, a tmpfs) must run here, not skip.
export TOUCHMEND_REQUIRE_FAULT_TESTS=1
cmake --workflow --preset dev
cmake --workflow --preset asan

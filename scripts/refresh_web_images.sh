#!/usr/bin/env bash
# Refreshes the web view's screenshots in docs/images/web/ from the browser
# tests (tests/web/), which otherwise write them into the build tree only.
# Needs a release build of chromod, chromo and web (scripts/build.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/release/bin
node tests/web/browser_test.mjs "$bin/chromod" build/release/web docs/images/web
node tests/web/operator_test.mjs "$bin/chromod" "$bin/chromo" build/release/web docs/images/web

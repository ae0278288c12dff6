# The two commands a new user needs (README): `make demo` and `make test`.
# Each does its own set-up (scripts/setup.sh is idempotent).
.PHONY: setup demo view test test-fast lint bench stress package qt6-check translations clean

setup:
	bash scripts/setup.sh

demo: setup
	bash scripts/demo.sh

# the web viewer of the demo's tileset on http://127.0.0.1:8716/ (WIT_VIEWER_PORT to change)
view: setup
	.venv/bin/python scripts/viewer.py serve out/demo/viewer

test: setup
	bash scripts/test.sh

# the fast subset: core tests (no QGIS: qgis made unimportable), not the slow end-to-end ones
test-fast: setup
	bash scripts/test.sh --core -m "not slow"

# ruff, mypy (the core's types), then plugins.qgis.org's security scan (Bandit, detect-secrets) of what the plugin ZIP ships, as make test
# runs them (bash scripts/lint.sh --fix: ruff's safe fixes only)
lint: setup
	bash scripts/lint.sh

bench: setup
	bash scripts/bench.sh

# not in CI: the 16-tile run and the killed-worker run repeated (benchmarks/stress_tiles.py; STRESS="--runs 3")
stress: setup
	bash -c 'source scripts/env.sh && .venv/bin/python benchmarks/stress_tiles.py $(STRESS)'

# dist/wit_citymodel-<version>.zip, checked against plugins.qgis.org's rules and scanned as it scans uploads;
# the maintainer's fields (email, tracker, repository, homepage) from .plugin-maintainer.ini or WIT_PLUGIN_*
package: setup
	bash scripts/package.sh

# not in CI (it needs a file of the QGIS repository): QGIS's own pyqt5_to_pyqt6.py on what the ZIP ships must
# leave no change (scripts/qt6_check.py; its PyPI requirements go into a venv outside the checkout, QT6_TOOL_VENV)
qt6-check: setup
	.venv/bin/python scripts/qt6_check.py "$(PYQT5_TO_PYQT6)"

translations: setup
	.venv/bin/python scripts/i18n.py

clean:
	rm -rf out dist .qgis-profile

# The two commands a new user needs (README): `make demo` and `make test`.
# Each does its own set-up (scripts/setup.sh is idempotent).
.PHONY: setup demo test bench package translations clean

setup:
	bash scripts/setup.sh

demo: setup
	bash scripts/demo.sh

test: setup
	bash scripts/test.sh

bench: setup
	bash scripts/bench.sh

package: setup
	bash scripts/package.sh

translations: setup
	.venv/bin/python scripts/i18n.py

clean:
	rm -rf out dist .qgis-profile

# `make test` and `make demo` each work alone on a fresh machine: they create .venv
# when it is missing and install the package with every extra into it first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.svrqp-installed

.PHONY: install test demo docs bench clean notebooks

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[all]"
	touch $(STAMP)

# One BLAS thread per process: pytest runs two workers on two cores, and oversubscribed
# OpenBLAS threads made a 933x933 Cholesky 100x slower on a loaded machine.
test: export OPENBLAS_NUM_THREADS = 1
test: export OMP_NUM_THREADS = 1
# The site is built first (strict, every warning an error): tests/docs opens its pages in a
# headless browser (SVRQP_BUILT_SITE), and checks that no raw TeX is left on them.
test: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir $(VENV)/site
	SVRQP_BUILT_SITE=$(VENV)/site $(PY) -m pytest -n 2 --dist loadfile -q tests
	$(PY) notebooks/build.py --check
# Notebooks one at a time: two kernels started at once can race for the same TCP port
# (ZMQError: Address already in use), a failure of the harness, not of a notebook.
	if ls notebooks/*.ipynb >/dev/null 2>&1; then $(PY) -m pytest -q --nbmake notebooks; fi

# The demo writes only its own files into demo-output/; re-running `make demo` replaces them.
demo: $(STAMP)
	$(VENV)/bin/svrqp demo --force

# Rebuild every notebook from its jupytext source (notebooks/NN_*.py), executed, outputs stored.
notebooks: export OPENBLAS_NUM_THREADS = 1
notebooks: $(STAMP)
	$(PY) notebooks/build.py

# The documentation site into site/ (open site/index.html); --strict turns a broken link into an error.
docs: $(STAMP)
	$(VENV)/bin/mkdocs build --strict --site-dir site

bench: $(STAMP)
	$(PY) benchmarks/epsilon_svr_vs_libsvm.py

clean:
	rm -rf $(VENV) demo-output site

# Everything a fresh machine needs: Python 3.11, make and git. The first target run creates
# the virtual environment and installs mitsonar with its pinned dependencies.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out

.PHONY: demo test install benchmark clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/mitsonar scan scenes/room_glass/scene.xml --pose 0,0,0 \
		--fov 60x40 --step 5 --out $(OUT)/demo

test: $(STAMP)
	$(PY) -m pytest -q

clean:
	rm -rf $(OUT) .pytest_cache

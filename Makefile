# One entry point for people and CI. `make run` sets up and runs the main job; `make test` sets up and
# runs the whole test suite (what .ci/run calls).
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | sha1sum | cut -c1-12)

.PHONY: setup browser compose run test lint bench tracks screenshots results clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	# torch is pinned to the local CPU wheel: any other spec pulls several GB of CUDA packages
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[dev,rl,tournament]"
	@rm -f $(VENV)/.installed-* && touch $(STAMP)

setup: $(STAMP)

browser:  ## Debian's chromium for the real-browser test (Playwright cannot download browsers here)
	bash scripts/install_browser.sh

compose:  ## Debian's docker-compose for the deployment test (`docker-compose config`; no engine needed)
	bash scripts/install_compose.sh

run: setup  ## set up, then start the race server on embedded defaults (SQLite file, local workers)
	$(BIN)/karting serve

# -n auto: one worker per core; --dist loadscope keeps a module's tests (and its module-scoped server) on one worker
test: lint browser compose  ## set up, then lint, type-check and run every test
	$(BIN)/python -m pytest -q -n auto --dist loadscope

lint: setup  ## ruff (rules, complexity limits), ruff format --check, mypy on every package ([tool.mypy] files)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

screenshots: setup browser  ## refresh docs/screenshots/ (the README's pictures) with the real-browser tests
	KARTING_README_SCREENSHOTS=1 $(BIN)/python -m pytest -q tests/web -k browser

# Every published result in docs/results/, each by the command its README names (about 3 h on the 2-core machine;
# the tournaments are stored in RESULTS_DB, so an interrupted run resumes them). Run it on a clean checkout: each
# manifest records the commit.
RESULTS_DB ?= runs/results.db
K := $(BIN)/karting
results: setup  ## regenerate every published result (docs/results/, the README's results block)
	@mkdir -p $(dir $(RESULTS_DB))
	$(K) reproduce paper --db $(RESULTS_DB)
	$(K) reproduce teams --db $(RESULTS_DB)
	$(K) tournament run --id mcts-lqng-fixed-lqng-vp --agents mcts-lqng,fixed-lqng --tracks oval,complex --races-per-pair 200 --seed 0 --kart paper --conditions varied-pace --db $(RESULTS_DB)
	$(K) tournament publish mcts-lqng-fixed-lqng-vp --out docs/results/varied-pace/mcts-lqng-fixed-lqng-vp --no-readme --db $(RESULTS_DB)
	$(K) tournament run --id mcts-rl-fixed-rl-vp --agents mcts-rl,fixed-rl --tracks oval,complex --races-per-pair 200 --seed 0 --kart paper --conditions varied-pace --db $(RESULTS_DB)
	$(K) tournament publish mcts-rl-fixed-rl-vp --out docs/results/varied-pace/mcts-rl-fixed-rl-vp --no-readme --db $(RESULTS_DB)
	$(K) reproduce field --races 40 --seed 0
	$(K) solo --agents mcts-rl,fixed-rl,e2e,mcts-lqng,fixed-lqng --tracks oval,complex,brands-hatch,norisring --races 1 --seed 0 --conditions paper --publish docs/results/solo
	$(K) scenarios run --scenarios overtake-straight --egos mcts-lqng,mcts-rl --opponents fixed-lqng,fixed-rl,e2e,mcts-lqng,mcts-rl --tracks oval,complex,brands-hatch --paces 0.95,0.97 --attempts 30 --seed 0 --publish docs/results/scenarios/overtake
	$(K) scenarios oracle --scenarios overtake-straight --opponents e2e,mcts-rl,fixed-lqng,fixed-rl --tracks oval,complex,brands-hatch --paces 0.95 --attempts 4 --seed 0 --lookahead 4.0 --base mcts-lqng --publish docs/results/scenarios/oracle --beside docs/results/scenarios/overtake/summary.json
	$(K) scenarios run --scenarios overtake-straight --egos fixed-lqng,fixed-rl --opponents fixed-lqng,fixed-rl,e2e,mcts-lqng,mcts-rl --tracks oval,complex,brands-hatch --paces 0.95,0.97 --attempts 10 --seed 0 --publish docs/results/scenarios/overtake-fixed-line
	$(K) scenarios run --scenarios defend-straight --egos mcts-lqng,mcts-rl,fixed-lqng,fixed-rl --opponents fixed-lqng,fixed-rl --tracks oval,complex,brands-hatch --attempts 30 --seed 0 --publish docs/results/scenarios/defend
	$(K) scenarios run --scenarios side-by-side-corner,lapping-straight,start-4-karts --egos mcts-lqng,mcts-rl,fixed-lqng,fixed-rl --opponents fixed-lqng,fixed-rl,e2e --tracks oval,complex,brands-hatch --attempts 20 --seed 0 --publish docs/results/scenarios/situations

bench: setup
	$(BIN)/python benchmarks/sim_step.py

tracks: setup  ## regenerate sim_core/tracks/*.json from ../shared/spec/tracks
	$(BIN)/python scripts/make_tracks.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .mypy_cache

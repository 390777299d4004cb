"""Shared fixtures: the real data folder (found like the library finds it) and file lists.

CI clones the repo to a fresh folder with ``../shared`` beside it, so the folder is located
with :func:`data_prep.sources.find_data_dir`, never by an absolute path. Tests that need
real data skip, with the reason, only when no data folder exists at all.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from data_prep.sources import DataNotFoundError, find_data_dir

NO_DATA_REASON = ("no real motion data: none of ../shared/data, $MOCAPVIZ_DATA_DIR or data/raw exists "
                  "(run `python -m data_prep download`)")


def _find() -> Path | None:
    try:
        return find_data_dir()
    except DataNotFoundError:
        return None


DATA_DIR = _find()


def _files(source: str, pattern: str) -> list[Path]:
    if DATA_DIR is None or not (DATA_DIR / source).is_dir():
        return []
    return sorted((DATA_DIR / source).glob(pattern))


CMU_FILES = _files("cmu", "*/*.bvh")
HDM05_FILES = _files("hdm05", "*/*.amc")
H36M_FILES = _files("h36m", "S*/*.txt")


# The tests `make test-fast` leaves out (``-m "not slow"``): each takes more than about 1.5 s on
# one shared CPU core (pytest --durations=0), or starts a browser, Blender, torchrun or a fresh
# interpreter. `make test` (CI) runs them all. A file name marks every test in it; "file::name"
# one test with all its parameters. Tests can also carry @pytest.mark.slow themselves.
SLOW = {
    "test_all_data_loads.py", "test_blender_roundtrip.py", "test_book_browser.py", "test_study_browser.py",
    "test_baselines.py::test_committed_checkpoint_loads_by_name_and_learnt",
    "test_baselines.py::test_dae_pretraining_learns_to_denoise_and_is_then_frozen",
    "test_ccnet_data.py::test_scaled_batch_is_the_scaled_motions_features",
    "test_ccnet_generate.py::test_first_generated_frame_keeps_the_bodys_root_height",
    "test_ccnet_generate.py::test_generated_motion_keeps_moving",
    "test_ccnet_generate.py::test_seed_pace_keeps_a_run_running",
    "test_ccnet_training.py::test_body_scale_run_keeps_the_scaled_normaliser_and_resumes_exactly",
    "test_ccnet_training.py::test_command_line_trains_and_exports",
    "test_ccnet_training.py::test_fine_tuning_starts_from_the_pretrained_network_and_its_normaliser",
    "test_ccnet_training.py::test_fine_tuning_keeps_dae_lstms_pretrained_autoencoder",
    "test_ccnet_training.py::test_latent_run_trains_logs_the_kl_and_resumes_exactly",
    "test_ccnet_training.py::test_quick_optimiser_fits_one_clip_better_than_copying_the_frame",
    "test_ccnet_training.py::test_resume_continues_the_same_loss_curve",
    "test_ccnet_training.py::test_resume_restores_the_best_so_far_from_the_log",
    "test_ccnet_training.py::test_torchrun_two_processes_gloo",
    "test_control.py::test_scripted_keys_bend_the_fed_controls_and_change_type",
    "test_control.py::test_scripted_keys_steer_the_character",
    "test_control.py::test_without_keys_the_session_is_the_free_running_generator",
    "test_cvae4d.py::test_both_phases_reduce_their_losses",
    "test_cvae4d.py::test_pca_baseline_and_vertex_errors",
    "test_cvae4d_completion.py::test_fitting_a_true_cycles_own_points_lowers_the_error",
    "test_cvae4d_prediction.py::test_training_learns_a_drift_and_round_trips",
    "test_finetune_table.py::test_quick_command_writes_the_table",
    "test_generate_cli.py::test_console_script_runs",
    "test_layers.py::test_importing_every_library_module_loads_no_data_prep",
    "test_one_step.py::test_root_bias_sees_a_standing_type_pushed_forward",
    "test_phase.py::test_a_phase_run_trains_a_ccnet_with_the_phase_in_its_control_and_baselines_refuse_it",
    "test_phase.py::test_real_walks_have_a_gait_rate_phase_with_the_left_foot_forward_at_zero",
    "test_phase.py::test_window_data_appends_the_phase_to_the_trajectory_control",
    "test_torch_mesh.py::test_gradcheck_float64",
    "test_type_prior.py::test_a_run_from_a_standing_start_keeps_its_legs_moving",
    "test_type_prior.py::test_the_type_prior_steadies_the_sampled_wavings_feet",
    "test_viz.py::test_headless_default_is_set_before_pyvista",
    "test_viz.py::test_viz_facade_exports_every_name_without_loading_pyvista",
}


def pytest_collection_modifyitems(config, items):
    seen = set()
    for item in items:
        names = {item.path.name, f"{item.path.name}::{item.originalname}"}
        seen |= names
        if names & SLOW:
            item.add_marker(pytest.mark.slow)
    files = {p.name for p in Path(__file__).parent.glob("test_*.py")}
    stale = sorted(s for s in SLOW - seen if s.split("::")[0] in files) if files <= seen else []
    if stale:  # the whole folder was collected and these name no test: a renamed or deleted test
        warnings.warn(pytest.PytestWarning(f"tests/conftest.py SLOW names no test: {', '.join(stale)}"))


@pytest.fixture(scope="session")
def data_dir() -> Path:
    if DATA_DIR is None:
        pytest.skip(NO_DATA_REASON)
    return DATA_DIR


def _need(files: list[Path], source: str) -> list[Path]:
    if DATA_DIR is None:
        pytest.skip(NO_DATA_REASON)
    if not files:
        pytest.fail(f"data folder {DATA_DIR} has no {source} files")
    return files


@pytest.fixture(scope="session")
def cmu_files() -> list[Path]:
    return _need(CMU_FILES, "cmu")


@pytest.fixture(scope="session")
def hdm05_files() -> list[Path]:
    return _need(HDM05_FILES, "hdm05")


@pytest.fixture(scope="session")
def h36m_files() -> list[Path]:
    return _need(H36M_FILES, "h36m")


@pytest.fixture(scope="session")
def ds(data_dir):
    """The quick CCNet dataset (``DatasetConfig.quick()``: HDM05, CMU and three Bandai takes of
    each content), built or read from ``cache/ccnet/`` once per session and shared by every test
    file on the CCNet features (a test file on another dataset defines its own ``ds``). Its
    arrays are read-only, so a test that would change the shared dataset fails where it writes;
    ``dataclasses.replace`` or ``with_vocabulary`` give a test its own variant."""
    from data_prep.ccnet_dataset import DatasetConfig, build_dataset
    quick = build_dataset(DatasetConfig.quick(), data_dir, progress=False)
    for a in (quick.x, quick.traj, quick.skel, quick.offsets, quick.parents):
        a.setflags(write=False)
    return quick


@pytest.fixture(scope="session")
def catalog(data_dir):
    from data_prep.catalog import build_catalog
    return build_catalog(data_dir, cache=False)


@pytest.fixture(scope="session")
def hdm05_asf():
    """ASF of an HDM05 actor, read once: ``hdm05_asf(amc_path)``."""
    from mocapviz.io.asfamc import read_asf
    cache = {}

    def get(amc: Path):
        actor = Path(amc).parent.name
        if actor not in cache:
            cache[actor] = read_asf(Path(amc).parent / f"HDM_{actor}.asf")
        return cache[actor]
    return get

import pytest
from test_nodes import *  # noqa: F401,F403  (the module's fixtures)
from test_nodes import test_sim_node_gated_alpha_proj_equals_the_core as once


@pytest.mark.parametrize("i", range(300))
def test_stress(ros, work, model_path, test_move, i):
    once(ros, work, model_path, test_move)

"""D-TOPOLOGY, D-KTOPO: grid interaction graphs and the derived coalition bound k_topo."""

from __future__ import annotations

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agspec.ir import topology as T


@pytest.mark.parametrize("rows, cols", [(2, 2), (4, 5), (5, 6), (6, 8), (20, 3)])
def test_k_topo_is_4_on_moore_grids_of_at_least_2x2(rows, cols):  # D-KTOPO, paper: "equals four"
    assert T.grid_k_topo(rows, cols, "moore", 1) == 4


@pytest.mark.parametrize("topology", ["von_neumann", "line"])
@pytest.mark.parametrize("rows, cols", [(2, 2), (5, 6), (6, 8)])
def test_k_topo_is_2_for_von_neumann_and_line(topology, rows, cols):  # D-KTOPO
    assert T.grid_k_topo(rows, cols, topology, 1) == 2


@pytest.mark.parametrize("topology", T.TOPOLOGIES)
def test_k_topo_is_1_on_a_1x1_grid(topology):  # a lone robot is a clique of one
    assert T.grid_k_topo(1, 1, topology, 1) == 1


def test_k_topo_of_thin_moore_grids_is_2():
    assert T.grid_k_topo(1, 6) == 2
    assert T.grid_k_topo(6, 1) == 2


def test_k_topo_grows_with_the_radius():  # clique number, never a free parameter
    assert T.grid_k_topo(7, 7, "moore", 2) == 9  # a 3x3 block
    assert T.grid_k_topo(7, 7, "von_neumann", 2) == 5  # the plus shape
    assert T.grid_k_topo(7, 7, "line", 2) == 3


def test_default_k_topo_is_4():  # a recipe alone is checked against the default Moore topology
    assert T.default_k_topo() == 4


def test_k_topo_of_an_empty_graph_is_0():
    assert T.k_topo(nx.Graph()) == 0


def test_the_three_relations_are_distinct_functions_with_the_same_v1_edges():  # D-TOPOLOGY
    graphs = [f(5, 6) for f in (T.manipulation_graph, T.handoff_graph, T.observation_graph)]
    assert len({T.manipulation_graph, T.handoff_graph, T.observation_graph}) == 3
    assert all(set(map(frozenset, g.edges)) == set(map(frozenset, graphs[0].edges)) for g in graphs)
    assert graphs[0] is not graphs[1]  # fresh graphs: a caller may mutate its own copy


def test_moore_neighbourhood_sizes():  # closed Moore radius 1: 8 neighbours inside, 3 at corners
    degrees = dict(T.observation_graph(5, 6).degree())
    assert degrees[(2, 2)] == 8
    assert degrees[(0, 0)] == 3
    assert degrees[(0, 3)] == 5


def test_line_topology_links_cells_of_a_row_only():  # RES-TOPOLOGY-LINE
    g = T.handoff_graph(3, 4, "line")
    assert g.has_edge((1, 0), (1, 1))
    assert not g.has_edge((0, 0), (1, 0))
    assert nx.number_connected_components(g) == 3


def test_radius_2_widens_manipulation_but_not_handoff_or_observation():  # RES-RADIUS
    manip = T.manipulation_graph(5, 5, "moore", 2)
    assert manip.has_edge((0, 0), (2, 2))
    for g in (T.handoff_graph(5, 5, "moore", 2), T.observation_graph(5, 5, "moore", 2)):
        assert not g.has_edge((0, 0), (2, 2))
        assert set(map(frozenset, g.edges)) == set(map(frozenset, T.handoff_graph(5, 5).edges))


def test_adjacent_agrees_with_the_graph():
    g = T.manipulation_graph(4, 4, "von_neumann")
    for a in g.nodes:
        for b in g.nodes:
            assert T.adjacent(a, b, "von_neumann") == g.has_edge(a, b)


@pytest.mark.parametrize("topology, radius", [("hex", 1), ("moore", 0), ("moore", 1.5), ("line", True)])
def test_bad_topology_or_radius_raises_topology_error(topology, radius):
    with pytest.raises(T.TopologyError):
        T.manipulation_graph(3, 3, topology, radius)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 9), st.integers(2, 9))
def test_moore_cliques_fit_in_a_2x2_block(rows, cols):  # paper: coalitions lie in a 2x2 block
    g = T.manipulation_graph(rows, cols)
    for clique in nx.find_cliques(g):
        assert max(i for i, _ in clique) - min(i for i, _ in clique) <= 1
        assert max(j for _, j in clique) - min(j for _, j in clique) <= 1
    assert T.k_topo(g) == 4

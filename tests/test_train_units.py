"""The trainer's parts against hand computations (spec/16-training.md): network shapes and parameter
counts, masks, GAE, the mixer's monotonicity, the schedules, the evaluation action, the replay."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

torch = pytest.importorskip("torch", reason="the trainer needs PyTorch: pip install 'agspec[train]'")
torch.set_num_threads(1)  # small tensors: one thread is fastest and the machine is shared

from agspec.checkpoint import nets  # noqa: E402
from agspec.train.api import resolve_config  # noqa: E402
from agspec.train.ppo import actor_frozen, entropy_coefficient, explained_variance, gae  # noqa: E402
from agspec.train.qmix import Replay, epsilon  # noqa: E402

OBS, A = 1566, 114


def gen(seed=0):
    return torch.Generator().manual_seed(seed)


def linear(i, o):
    return i * o + o


def layer_norm(n):
    return 2 * n


def test_shared_actor_shapes_and_parameter_count():  # T-ACTOR
    actor = nets.SharedActor(256, 2, gen())
    assert actor(torch.zeros(7, OBS)).shape == (7, A)
    block = layer_norm(256) + 2 * linear(256, 256)
    expected = layer_norm(OBS) + linear(OBS, 256) + 2 * block + linear(256, 6) + linear(256, A)
    assert nets.parameter_count(actor) == expected == 699_316


def test_family_head_adds_one_logit_per_family():  # T-ACTOR
    actor = nets.SharedActor(16, 1, gen())
    with torch.no_grad():
        actor.slot_head.weight.zero_()
        actor.slot_head.bias.zero_()
        actor.family_head.weight.zero_()
        actor.family_head.bias.copy_(torch.arange(6, dtype=torch.float32))
    logits = actor(torch.rand(1, OBS))[0]
    assert logits[0] == 0 and logits[1] == 1 and set(logits[2:34].tolist()) == {2.0}
    assert set(logits[34:42].tolist()) == {3.0} and set(logits[42:50].tolist()) == {4.0}
    assert set(logits[50:].tolist()) == {5.0}


def test_initialization_is_orthogonal_with_the_original_gains():  # T-ACTOR, RES-ACTOR-DETAILS
    actor = nets.SharedActor(256, 2, gen())
    w = actor.trunk.blocks[0].fc2.weight
    assert torch.allclose(w @ w.T, 0.25 * torch.eye(256), atol=1e-4)  # gain 0.5
    head = actor.slot_head.weight  # gain 0.01, shape 114 x 256: orthonormal rows scaled
    assert torch.allclose(head @ head.T, 1e-4 * torch.eye(A), atol=1e-7)
    assert torch.count_nonzero(actor.trunk.encoder.bias) == 0


def test_critics_read_what_the_table_says():  # T-CRITIC
    ippo = nets.ValueNet(OBS, 256, 2, gen())
    assert ippo(torch.zeros(5, OBS)).shape == (5,)
    block = layer_norm(256) + 2 * linear(256, 256)
    assert nets.parameter_count(ippo) == layer_norm(OBS) + linear(OBS, 256) + 2 * block + linear(256, 1)
    from agspec.train.ppo import PPOLearner

    config = resolve_config("mappo", "flow-easy", 0)
    learner = PPOLearner(config, 20, 429, torch.device("cpu"), gen(), gen(1))
    x = learner.critic_input(torch.zeros(2, 20, OBS), torch.ones(2, 429))
    assert x.shape == (2, 20, 429 + OBS) and bool((x[..., :429] == 1).all()) and bool((x[..., 429:] == 0).all())


def test_qnet_and_mixer_parameter_counts():  # T-QNET, T-MIXER
    q = nets.QNet([256, 256], gen())
    assert q(torch.zeros(3, OBS)).shape == (3, A)
    assert nets.parameter_count(q) == linear(OBS, 256) + linear(256, 256) + linear(256, A) == 496_242
    n, s = 30, 650
    mixer = nets.QMixer(n, s, 64, 128, 2, gen())
    hyper = linear(s, 128) + linear(128, 128)
    expected = (hyper + linear(128, n * 64)) + linear(s, 64) + (hyper + linear(128, 64)) + (hyper + linear(128, 1))
    assert nets.parameter_count(mixer) == expected
    assert mixer(torch.zeros(4, n), torch.zeros(4, s)).shape == (4,)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 7), st.floats(0.01, 50.0))
def test_mixer_is_monotonic_in_every_agent(seed, agent, delta):  # T-MIXER
    torch.manual_seed(0)  # only the test's inputs; the mixer draws from its own generator
    g = gen(seed)
    mixer = nets.QMixer(8, 12, 16, 32, 2, g)
    q = torch.randn(5, 8, generator=g) * 10
    state = torch.rand(5, 12, generator=g)
    bumped = q.clone()
    bumped[:, agent] += delta
    with torch.no_grad():
        assert bool((mixer(bumped, state) >= mixer(q, state) - 1e-5).all())
    q.requires_grad_(True)
    mixer(q, state).sum().backward()
    assert bool((q.grad >= 0).all())


def test_a_masked_action_has_probability_zero_and_is_never_chosen():  # T-MASK
    logits = torch.randn(64, A, generator=gen(3)) * 30
    mask = torch.zeros(64, A, dtype=torch.int8)
    mask[:, 0] = 1
    mask[:, 50:53] = 1
    probs = torch.softmax(nets.masked_logits(logits, mask), dim=-1)
    assert bool((probs[mask == 0] == 0).all())
    draws = torch.multinomial(probs, 200, replacement=True, generator=gen(4))
    assert bool(mask.gather(1, draws).all())
    assert bool(mask.gather(1, nets.greedy(logits, mask).unsqueeze(1)).all())


def test_greedy_takes_the_first_index_on_ties():  # T-EVAL-ACTION
    scores = torch.zeros(1, A)
    scores[0, [3, 7, 60]] = 5.0
    mask = torch.ones(1, A, dtype=torch.int8)
    assert int(nets.greedy(scores, mask)[0]) == 3
    mask[0, 3] = 0
    assert int(nets.greedy(scores, mask)[0]) == 7


def test_gae_against_a_hand_computation():  # T-GAE, RES-TRUNCATION-TERMINAL
    rewards = torch.tensor([[1.0], [2.0], [3.0]])
    values = torch.tensor([[0.5], [0.4], [0.3]])
    dones = torch.tensor([False, True, False])
    adv, ret = gae(rewards, values, dones, torch.tensor([0.2]), gamma=0.9, lam=0.8)
    # t=2: 3 + 0.9*0.2 - 0.3 = 2.88; t=1 (done): 2 - 0.4 = 1.6; t=0: 1 + 0.9*0.4 - 0.5 + 0.9*0.8*1.6 = 2.012
    assert torch.allclose(adv[:, 0], torch.tensor([2.012, 1.6, 2.88]))
    assert torch.allclose(ret[:, 0], torch.tensor([2.512, 2.0, 3.18]))


def test_gae_keeps_agents_and_copies_apart():  # T-GAE
    rewards = torch.tensor([[[1.0, 0.0], [0.0, 0.0]]])  # [T=1, E=2, R=2]
    values = torch.zeros(1, 2, 2)
    adv, _ = gae(rewards, values, torch.tensor([[False, True]]), torch.tensor([[1.0, 2.0], [3.0, 4.0]]), 0.5, 1.0)
    assert adv[0].tolist() == [[1.5, 1.0], [0.0, 0.0]]  # copy 1 ended: no bootstrap


def test_explained_variance():
    target = torch.tensor([1.0, 2.0, 3.0, 4.0])
    assert explained_variance(target, target) == 1.0
    assert explained_variance(torch.zeros(4), target) == pytest.approx(1 - float(torch.var(target)) / float(torch.var(target)) + 0.0)
    assert explained_variance(torch.zeros(4), torch.ones(4)) == 0.0


def test_entropy_schedule_and_warmup():  # T-ENTROPY-SCHEDULE, T-WARMUP
    config = resolve_config("ippo", "flow-easy", 0)
    budget = 1_536_000
    assert entropy_coefficient(config, 0) == pytest.approx(0.015)
    assert entropy_coefficient(config, 1600) == pytest.approx(0.015 - 0.014 * 1600 / budget)
    assert entropy_coefficient(config, budget // 2) == pytest.approx(0.008)
    assert entropy_coefficient(config, budget) == pytest.approx(0.001)
    assert [actor_frozen(config, n) for n in (1600, 3200, 4800)] == [True, True, False]


def test_epsilon_schedule():  # T-QMIX-EXPLORATION
    config = resolve_config("qmix", "flow-easy", 0)
    decay = int(1_536_000 * 0.75)
    assert epsilon(config, 1) == 1.0
    assert epsilon(config, 1 + decay // 2) == pytest.approx(0.525)
    assert epsilon(config, 1 + decay) == pytest.approx(0.05)
    assert epsilon(config, 1_536_000) == 0.05


def _transition(rng, n=3, s=9):
    obs = np.where(rng.random((n, OBS)) < 0.02, rng.random((n, OBS)), 0).astype(np.float32)
    nxt = np.where(rng.random((n, OBS)) < 0.02, rng.random((n, OBS)), 0).astype(np.float32)
    mask = (rng.random((n, A)) < 0.1).astype(np.int8)
    mask[:, 0] = 1
    return (obs, mask, rng.integers(0, A, n), float(rng.normal()), nxt, mask[::-1].copy(), bool(rng.random() < 0.5),
            rng.random(s).astype(np.float32), np.zeros(s, np.float32))


def test_replay_is_exact_fifo_and_survives_a_checkpoint(tmp_path):  # T-REPLAY
    rng = np.random.default_rng(0)
    replay = Replay(4, 3, OBS, A, 9)
    added = [_transition(rng) for _ in range(6)]
    for t in added:
        replay.add(*t)
    assert len(replay) == 4
    batch = replay.sample(4, np.random.default_rng(1))
    kept = added[2:]  # the two oldest were overwritten
    for row in range(4):
        match = [t for t in kept if np.array_equal(t[0], batch["obs"][row])]
        assert len(match) == 1
        t = match[0]
        assert np.array_equal(batch["mask"][row], t[1]) and np.array_equal(batch["actions"][row], t[2])
        assert batch["reward"][row] == np.float32(t[3]) and np.array_equal(batch["next_obs"][row], t[4])
        assert np.array_equal(batch["next_mask"][row], t[5]) and batch["done"][row] == float(t[6])
        assert np.array_equal(batch["state"][row], t[7])
    replay.save(tmp_path / "r.npz")
    again = Replay.load(tmp_path / "r.npz")
    assert again.position == replay.position and len(again) == 4
    a, b = replay.sample(4, np.random.default_rng(5)), again.sample(4, np.random.default_rng(5))
    assert all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("algorithm", ["mappo", "qmix"])
def test_optimizers_are_adamw_with_the_tables_settings(algorithm):  # T-ADAMW, RES-ADAMW-DEFAULTS
    config = resolve_config(algorithm, "flow-easy", 0)
    dev = torch.device("cpu")
    if algorithm == "qmix":
        from agspec.train.qmix import QMIXLearner

        learner = QMIXLearner(config, 20, 429, dev, gen(), gen(1), np.random.default_rng(0))
        opts = {"q": learner.opt}
        assert sum(p.numel() for g in learner.opt.param_groups for p in g["params"]) == (
            nets.parameter_count(learner.qnet) + nets.parameter_count(learner.mixer))
    else:
        from agspec.train.ppo import PPOLearner

        learner = PPOLearner(config, 20, 429, dev, gen(), gen(1))
        opts = {"actor": learner.actor_opt, "critic": learner.critic_opt}
    for role, opt in opts.items():
        assert type(opt) is torch.optim.AdamW
        group = opt.param_groups[0]
        assert (group["lr"], group["eps"], group["weight_decay"], group["betas"]) == (
            config["lr"][role], 1e-5, 0.01, (0.9, 0.999))


def test_clipped_objectives_against_hand_computations():  # T-PPO-UPDATE, RES-VALUE-LOSS
    from agspec.train.ppo import clipped_surrogate, clipped_value_loss

    ratio, adv = torch.tensor([0.5, 1.05, 1.5]), torch.tensor([1.0, -1.0, 2.0])
    # min(0.5, 0.9) = 0.5; min(-1.05, -1.05) = -1.05; min(3.0, 1.1 * 2) = 2.2
    assert float(clipped_surrogate(ratio, adv, 0.10)) == pytest.approx((0.5 - 1.05 + 2.2) / 3)
    v, old, ret = torch.tensor([1.0]), torch.tensor([0.0]), torch.tensor([2.0])
    # V_old + clip(1, ±0.2) = 0.2: squared max((1-2)², (0.2-2)²) = 3.24; Huber max(0.5·1², 1.8 - 0.5) = 1.3
    assert float(clipped_value_loss(v, old, ret, 0.20, "mse")) == pytest.approx(3.24)
    assert float(clipped_value_loss(v, old, ret, 0.20, "huber")) == pytest.approx(1.3)


def _learner_and_batch(algorithm="ippo", **overrides):
    from agspec.train.ppo import PPOLearner, Rollout

    config = resolve_config(algorithm, "flow-easy", 0, {"ppo.minibatch": 16, **overrides})
    learner = PPOLearner(config, 16, 8, torch.device("cpu"), gen(), gen(1))
    g = gen(2)
    obs = (torch.rand(4, 1, 16, OBS, generator=g) < 0.02).float()
    mask = (torch.rand(4, 1, 16, A, generator=g) < 0.2).to(torch.int8)
    mask[..., 0] = 1
    actions, logp, values = learner.act(obs, mask, torch.rand(4, 1, 8, generator=g))
    batch = Rollout(obs, mask, torch.rand(4, 1, 8, generator=g), actions, logp, values,
                    torch.randn(4, 1, 16, generator=g), torch.zeros(4, 1, dtype=torch.bool), torch.zeros(1, 16))
    return learner, batch


def _params(module):
    return [p.detach().clone() for p in module.parameters()]


def test_an_update_runs_the_tables_epochs_and_minibatches_and_the_kl_stop_ends_it():  # T-PPO-UPDATE, RES-KL-STOP
    learner, batch = _learner_and_batch(**{"ppo.target_kl": 1e6})
    stats = learner.update(batch, steps_done=10_000)
    assert stats["minibatches"] == 4 * 4 and stats["samples"] == 4 * 64 and not stats["kl_early_stop"]
    learner, batch = _learner_and_batch(**{"ppo.target_kl": 1e-12})
    stats = learner.update(batch, steps_done=10_000)
    # a minibatch's KL is measured before its own step: the first sees the rollout's policy (KL 0), the
    # second the policy after one step, which exceeds 1.5 x target, and the update ends there
    assert stats["kl_early_stop"] and stats["minibatches"] == 2


def test_during_the_warm_up_only_the_critic_learns():  # T-WARMUP
    learner, batch = _learner_and_batch(**{"ppo.target_kl": 1e-12})
    actor, critic = _params(learner.actor), _params(learner.critic)
    stats = learner.update(batch, steps_done=3200)
    assert not stats["actor_updated"] and not stats["kl_early_stop"] and stats["minibatches"] == 16
    assert all(torch.equal(a, b) for a, b in zip(actor, _params(learner.actor)))
    assert not all(torch.equal(a, b) for a, b in zip(critic, _params(learner.critic)))


@pytest.mark.parametrize("done", [True, False])
def test_td_target_is_single_network_with_mse(done):  # T-QMIX-UPDATE
    from agspec.train.qmix import QMIXLearner

    config = resolve_config("qmix", "flow-easy", 0, {"replay.batch": 1})
    learner = QMIXLearner(config, 4, 6, torch.device("cpu"), gen(), gen(1), np.random.default_rng(0))
    rng = np.random.default_rng(3)
    t = _transition(rng, n=4, s=6)
    t = (*t[:6], done, t[7], rng.random(6).astype(np.float32))
    learner.replay.add(*t)
    with torch.no_grad():  # by hand: Q_tot of the chosen actions, target from the target networks only
        q = learner.qnet(torch.from_numpy(t[0]))
        chosen = q.gather(1, torch.from_numpy(t[2]).long().unsqueeze(1)).T
        q_tot = learner.mixer(chosen, torch.from_numpy(t[7]).unsqueeze(0))
        nxt = learner.target_qnet(torch.from_numpy(t[4])).masked_fill(torch.from_numpy(t[5]) == 0, -1e9).max(1).values
        boot = learner.target_mixer(nxt.unsqueeze(0), torch.from_numpy(t[8]).unsqueeze(0))
        target = t[3] + (0.0 if done else 0.99 * float(boot))
    stats = learner.train_step()
    assert stats["td_loss"] == pytest.approx((float(q_tot) - target) ** 2, rel=1e-5)


def _legal_masks(rng: np.random.Generator, n: int) -> np.ndarray:
    """Masks as O-MASK makes them: idle always legal, then a few legal actions in a few families."""
    mask = np.zeros((n, A), dtype=np.int8)
    mask[:, 0] = 1
    for row in mask:
        row[rng.choice(np.arange(1, A), size=int(rng.integers(1, 12)), replace=False)] = 1
    return mask


def _uniformity(probs: torch.Tensor, mask: np.ndarray) -> tuple[float, float]:
    """(largest |p/u - 1| over legal actions, largest |family mass - uniform's|) against uniform masked."""
    legal = torch.from_numpy(mask).bool()
    uniform = legal.float() / legal.sum(-1, keepdim=True)
    ratio = (probs[legal] / uniform[legal] - 1).abs().max()
    fam = nets.action_families()
    mass = torch.zeros(probs.shape[0], 6).index_add_(1, fam, probs - uniform).abs().max()
    return float(ratio), float(mass)


def test_the_untrained_actor_is_uniform_over_legal_actions():  # T-ACTOR, T-MASK, RES-UNTRAINED-ACTOR
    """The heads' gain 0.01 makes every logit about 0, so the masked softmax is uniform over the legal
    flat actions — not uniform over families then slots; a gain-1 head or a family-then-slot policy
    fails the same check."""
    rng = np.random.default_rng(0)
    obs = torch.from_numpy((rng.random((64, OBS)) < 0.01).astype(np.float32))  # ~1 % non-zero (A-OBS-VECTOR)
    mask = _legal_masks(rng, 64)
    for seed in range(3):
        actor = nets.SharedActor(256, 2, gen(seed))
        with torch.no_grad():
            probs = torch.softmax(nets.masked_logits(actor(obs), torch.from_numpy(mask)), -1)
        ratio, family = _uniformity(probs, mask)
        assert ratio < 0.1 and family < 0.03, (seed, ratio, family)
    # mutant 1: heads with gain 1 (no longer near-uniform)
    loud = nets.SharedActor(256, 2, gen(0))
    nets.orthogonal(loud.slot_head, 1.0, gen(1))
    with torch.no_grad():
        probs = torch.softmax(nets.masked_logits(loud(obs), torch.from_numpy(mask)), -1)
    assert _uniformity(probs, mask)[0] > 0.1
    # mutant 2: uniform over the legal families, then over the legal slots of the family drawn
    legal = torch.from_numpy(mask).float()
    fam = nets.action_families()
    per_family = torch.zeros(64, 6).index_add_(1, fam, legal)
    families = (per_family > 0).sum(-1, keepdim=True)
    nested = legal / per_family[:, fam].clamp(min=1) / families
    assert _uniformity(nested, mask)[1] > 0.1

"""The networks of tab:marlconfig (spec/16-training.md, T-ACTOR, T-CRITIC, T-QNET, T-MIXER).

Every network is built from an explicit ``torch.Generator`` so that a run's initial weights depend
on its seed only, never on torch's global random state (T-DETERMINISM).
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from agspec.formats.actions import DELIVER, HANDOFF0, IDLE, N_ACTIONS, OP0, PICK0, RECEIVE0
from agspec.marl.encoding import OBS_DIM

# T-ACTOR: the six action families of O-ACTION-ENCODING, one family logit each
FAMILIES = ("idle", "deliver", "pick", "handoff", "receive", "operation")
NEG_INF = -1e9  # T-MASK: the logit of a masked action (probability exactly 0 after softmax)


def action_families() -> torch.Tensor:
    """family index of each of the 114 actions (O-ACTION-ENCODING)."""
    fam = torch.empty(N_ACTIONS, dtype=torch.long)
    fam[IDLE], fam[DELIVER] = 0, 1
    fam[PICK0:HANDOFF0], fam[HANDOFF0:RECEIVE0], fam[RECEIVE0:OP0], fam[OP0:] = 2, 3, 4, 5
    return fam


def orthogonal(layer: nn.Linear, gain: float, gen: torch.Generator) -> nn.Linear:
    """T-ACTOR: orthogonal weights with ``gain``, zero biases (torch's orthogonal_ with the run's generator)."""
    nn.init.orthogonal_(layer.weight, gain, generator=gen)
    nn.init.zeros_(layer.bias)
    return layer


def torch_default(layer: nn.Linear, gen: torch.Generator) -> nn.Linear:
    """T-QNET: torch's own ``nn.Linear`` initialization, drawn from the run's generator."""
    nn.init.kaiming_uniform_(layer.weight, a=math.sqrt(5), generator=gen)
    bound = 1.0 / math.sqrt(layer.in_features) if layer.in_features > 0 else 0.0
    nn.init.uniform_(layer.bias, -bound, bound, generator=gen)
    return layer


class ResidualBlock(nn.Module):
    """x + tanh(W2 tanh(W1 LayerNorm(x))) (T-ACTOR; RES-ACTOR-DETAILS: gains √2 and 0.5)."""

    def __init__(self, width: int, gen: torch.Generator):
        super().__init__()
        self.norm = nn.LayerNorm(width)
        self.fc1 = orthogonal(nn.Linear(width, width), math.sqrt(2.0), gen)
        self.fc2 = orthogonal(nn.Linear(width, width), 0.5, gen)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + torch.tanh(self.fc2(torch.tanh(self.fc1(self.norm(x)))))


class Trunk(nn.Module):
    """LayerNorm of the input, a linear encoder to ``width`` with tanh, then residual blocks."""

    def __init__(self, in_dim: int, width: int, blocks: int, gen: torch.Generator):
        super().__init__()
        self.norm = nn.LayerNorm(in_dim)
        self.encoder = orthogonal(nn.Linear(in_dim, width), math.sqrt(2.0), gen)
        self.blocks = nn.Sequential(*(ResidualBlock(width, gen) for _ in range(blocks)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.blocks(torch.tanh(self.encoder(self.norm(x))))


class SharedActor(nn.Module):
    """T-ACTOR: the shared actor of IPPO and MAPPO; logits = slot head + family head of the action's family."""

    def __init__(self, width: int, blocks: int, gen: torch.Generator, obs_dim: int = OBS_DIM):
        super().__init__()
        self.trunk = Trunk(obs_dim, width, blocks, gen)
        self.family_head = orthogonal(nn.Linear(width, len(FAMILIES)), 0.01, gen)
        self.slot_head = orthogonal(nn.Linear(width, N_ACTIONS), 0.01, gen)
        self.register_buffer("family_of", action_families(), persistent=False)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        hidden = self.trunk(obs)
        return self.slot_head(hidden) + self.family_head(hidden).index_select(-1, self.family_of)


class ValueNet(nn.Module):
    """T-CRITIC: the same trunk with one linear output (gain 1)."""

    def __init__(self, in_dim: int, width: int, blocks: int, gen: torch.Generator):
        super().__init__()
        self.trunk = Trunk(in_dim, width, blocks, gen)
        self.out = orthogonal(nn.Linear(width, 1), 1.0, gen)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(self.trunk(x)).squeeze(-1)


def mlp(in_dim: int, hidden: list[int], out_dim: int, gen: torch.Generator) -> nn.Sequential:
    """A tanh multilayer perceptron with torch's default initialization (T-QNET, T-MIXER)."""
    layers: list[nn.Module] = []
    prev = in_dim
    for width in hidden:
        layers += [torch_default(nn.Linear(prev, width), gen), nn.Tanh()]
        prev = width
    layers.append(torch_default(nn.Linear(prev, out_dim), gen))
    return nn.Sequential(*layers)


class QNet(nn.Module):
    """T-QNET: the shared Q network, observation -> one value per action."""

    def __init__(self, hidden: list[int], gen: torch.Generator, obs_dim: int = OBS_DIM):
        super().__init__()
        self.net = mlp(obs_dim, list(hidden), N_ACTIONS, gen)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net(obs)


class QMixer(nn.Module):
    """T-MIXER: Q_tot = w2ᵀ elu(W1ᵀ q + b1) + b2 with W1, w2 = softplus(hypernetworks(state)) ≥ 0,
    so that ∂Q_tot/∂q_u ≥ 0 for every agent u (monotonic)."""

    def __init__(self, n_agents: int, state_dim: int, width: int, hyper_hidden: int, hyper_layers: int,
                 gen: torch.Generator):
        super().__init__()
        self.n_agents, self.width = n_agents, width
        hidden = [hyper_hidden] * hyper_layers
        self.hyper_w1 = mlp(state_dim, hidden, n_agents * width, gen)
        self.hyper_b1 = torch_default(nn.Linear(state_dim, width), gen)
        self.hyper_w2 = mlp(state_dim, hidden, width, gen)
        self.hyper_b2 = mlp(state_dim, hidden, 1, gen)

    def forward(self, agent_qs: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        """agent_qs [B, n_agents], state [B, state_dim] -> Q_tot [B]."""
        batch = agent_qs.shape[0]
        w1 = F.softplus(self.hyper_w1(state)).view(batch, self.n_agents, self.width)
        b1 = self.hyper_b1(state)
        hidden = F.elu((agent_qs.unsqueeze(-1) * w1).sum(dim=1) + b1)
        w2 = F.softplus(self.hyper_w2(state))
        return (hidden * w2).sum(dim=1) + self.hyper_b2(state).squeeze(-1)


def masked_logits(logits: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """T-MASK: masked actions get NEG_INF (softmax probability 0); O-MASK always allows idle."""
    return logits.masked_fill(mask == 0, NEG_INF)


def greedy(scores: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """T-EVAL-ACTION: the masked argmax, first index on ties (torch.argmax returns the first maximum)."""
    return masked_logits(scores, mask).argmax(dim=-1)


def parameter_count(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())

"""The conditional VAEs of paper Table 1 in PyTorch.

Each CVAE has an encoder q(z | x, c) and a decoder p(x | z, c), both multilayer perceptrons of
`depth` hidden layers of `width` units with Softplus between them and an identity last layer
that outputs a mean and a log-variance. The decoder's input is the contract's vector
[encoded conditions, z, zeros] of width `spec.input_width` (docs/model-format.md); the encoder
sees [encoded conditions, encoded outputs]. Everything here works on encoded values.
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from sssphere.learn.spec import ModelSpec

LOG_2PI = math.log(2.0 * math.pi)


class GaussianMLP(nn.Module):
    """x (batch, n_in) → (mean, logvar), each (batch, n_out): `depth` Softplus hidden layers."""

    def __init__(self, n_in: int, width: int, n_out: int, depth: int = 2):
        super().__init__()
        sizes = [n_in] + [width] * depth
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))
        self.last = nn.Linear(sizes[-1], 2 * n_out)
        self.n_out = n_out

    def linear_layers(self) -> list[nn.Linear]:
        return [*self.hidden, self.last]

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = x
        for layer in self.hidden:
            h = F.softplus(layer(h))
        y = self.last(h)
        return y[:, : self.n_out], y[:, self.n_out:]


class CVAE(nn.Module):
    """Encoder and decoder of one model of `spec` (LengthGen, PathGen or EventGen)."""

    def __init__(self, spec: ModelSpec):
        super().__init__()
        self.spec = spec
        n_c, n_x, n_z = len(spec.conditions), len(spec.outputs), spec.latent_dim
        self.encoder = GaussianMLP(n_c + n_x, spec.width, n_z, spec.depth)
        self.decoder = GaussianMLP(spec.input_width, spec.width, n_x, spec.depth)
        # The padding columns of the decoder's first layer see only zeros: start them at zero
        # (they get no gradient, and AdamW's decay keeps them there) so the file is tidy.
        with torch.no_grad():
            self.decoder.hidden[0].weight[:, n_c + n_z:] = 0.0

    def decoder_input(self, c: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """[c, z, zeros] of width spec.input_width."""
        pad = self.spec.input_width - c.shape[1] - z.shape[1]
        return torch.cat([c, z, c.new_zeros(c.shape[0], pad)], dim=1)

    def forward(self, c: torch.Tensor, x: torch.Tensor, noise: torch.Tensor):
        """Encode (x, c), draw z = μ_z + σ_z·noise, decode.

        Returns (x_mean, x_logvar, z_mean, z_logvar)."""
        z_mean, z_logvar = self.encoder(torch.cat([c, x], dim=1))
        z = z_mean + torch.exp(0.5 * z_logvar) * noise
        x_mean, x_logvar = self.decoder(self.decoder_input(c, z))
        return x_mean, x_logvar, z_mean, z_logvar


def gaussian_nll(x: torch.Tensor, mean: torch.Tensor, logvar: torch.Tensor) -> torch.Tensor:
    """−ln N(x; mean, e^logvar) summed over the last axis, per sample (batch,)."""
    return 0.5 * (logvar + (x - mean) ** 2 * torch.exp(-logvar) + LOG_2PI).sum(dim=1)


def kl_per_dim(z_mean: torch.Tensor, z_logvar: torch.Tensor) -> torch.Tensor:
    """KL(N(μ, e^ℓ) ‖ N(0, 1)) per sample and latent dimension (batch, L), in nats."""
    return 0.5 * (z_mean ** 2 + torch.exp(z_logvar) - 1.0 - z_logvar)

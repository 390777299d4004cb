"""CCNet run one frame at a time (the fast-WaveNet queue idea): incremental generation.

Each block keeps its last d_i inputs in a ring, so a new frame costs one small matmul chain per
block instead of recomputing the receptive field. Two engines with the same interface
(:class:`mocapviz.models.protocol.Stepper`) and results to float rounding: :class:`CCNetStepper`
on torch tensors (better for large batches) and :class:`NumpyStepper` on numpy arrays (for a few
characters: a frame is ~140 tiny calls and numpy's per-call cost is a fraction of torch's).
Both equal ``CCNet.forward`` (eval mode) on the whole sequence, to float rounding.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import torch

from mocapviz.models.ccnet_extensions import phase_basis, phase_waves

if TYPE_CHECKING:
    from mocapviz.models.ccnet import CCNet


@dataclass
class _StepWeights:
    enc_w: torch.Tensor
    enc_b: torch.Tensor
    ctrl_static_w: torch.Tensor   # (n_skel + n_types, nb * 2C)
    ctrl_traj_w: torch.Tensor     # (n_traj, nb * 2C)
    ctrl_b: torch.Tensor          # (nb * 2C,)
    past_w: list = field(default_factory=list)
    cur_w: list = field(default_factory=list)
    res_w: list = field(default_factory=list)
    skip_w: torch.Tensor = None   # (nb * C, S)
    skip_b: torch.Tensor = None
    dec_w: torch.Tensor = None
    dec_b: torch.Tensor = None
    z_w: torch.Tensor = None      # (latent, S): z's projection onto the skip sum (cfg.latent only)
    phase_w: torch.Tensor = None  # (2K (S + 1), n_out): the phase-functioned decoder's (cfg.phase_harmonics only)


class CCNetStepper:
    """Incremental CCNet: one frame per call, past block inputs kept in a ring buffer (hist).

    Equal to ``CCNet.forward`` (eval mode) on the whole sequence, to float rounding. The gated
    unit uses sigmoid(b) = (1 + tanh(b/2)) / 2 so one tanh serves both halves (the gate half
    of the weights is pre-scaled by 1/2, and the 1/2 folded into the residual/skip weights);
    skip projections of all blocks are one matmul on the concatenated gate outputs.
    """

    def __init__(self, model: "CCNet", batch: int = 1, dtype=torch.float32):
        """Copies the weights of ``model`` (retake a stepper after changing the model)."""
        self.cfg = cfg = model.cfg
        self.batch = batch
        self._without_z = torch.from_numpy(cfg.without_z_columns)
        c = cfg.channels
        with torch.no_grad():
            gate_scale = torch.cat([torch.ones(c), torch.full((c,), 0.5)]).to(dtype)
            st, tr, bias = [], [], []
            w = _StepWeights(enc_w=model.encoder.weight[:, :, 0].T.to(dtype).contiguous(),
                             enc_b=model.encoder.bias.to(dtype).clone(), ctrl_static_w=None,
                             ctrl_traj_w=None, ctrl_b=None)
            skip_ws, skip_b = [], 0
            for blk in model.blocks:
                cw = blk.conv.weight.to(dtype) * gate_scale[:, None, None]
                w.past_w.append(cw[:, :, 0].T.contiguous())
                w.cur_w.append(cw[:, :, 1].T.contiguous())
                st.append(torch.cat([blk.ctrl_skel.weight[:, :, 0], blk.ctrl_type.weight[:, :, 0]], 1).to(dtype)
                          * gate_scale[:, None])
                tr.append(blk.ctrl_traj.weight[:, :, 0].to(dtype) * gate_scale[:, None])
                bias.append(blk.conv.bias.to(dtype) * gate_scale)
                w.res_w.append((0.5 * blk.res.weight[:, :, 0].T).to(dtype).contiguous())
                skip_ws.append((0.5 * blk.skip.weight[:, :, 0].T).to(dtype))
                if blk.skip.bias is not None:
                    skip_b = skip_b + blk.skip.bias.to(dtype)
            w.ctrl_static_w = torch.cat(st, 0).T.contiguous()
            w.ctrl_traj_w = torch.cat(tr, 0).T.contiguous()
            w.ctrl_b = torch.cat(bias)
            w.skip_w = torch.cat(skip_ws, 0).contiguous()
            w.skip_b = skip_b.clone() if torch.is_tensor(skip_b) else torch.zeros(cfg.skip_channels, dtype=dtype)
            w.dec_w = model.decoder.weight[:, :, 0].T.to(dtype).contiguous()
            w.dec_b = model.decoder.bias.to(dtype).clone()
            if cfg.latent:
                w.z_w = model.z_in.weight.T.to(dtype).contiguous()
            if cfg.phase_harmonics:
                w.phase_w = model.phase_decoder.weight.T.to(dtype).contiguous()
        self.w = w
        self.dtype = dtype
        self._static = None
        self.reset()

    def reset(self):
        """Forget the past (zeros, as the causal padding of the full model)."""
        nb, r = len(self.cfg.dilations), max(self.cfg.dilations)
        # hist[t % R, i] holds block i's input at frame t; block i reads frame t - d_i.
        self.hist = torch.zeros(r, nb, self.batch, self.cfg.channels, dtype=self.dtype)
        self._past_index = [torch.tensor([(p - d) % r for d in self.cfg.dilations]) for p in range(r)]
        self._blocks = torch.arange(nb)
        self._past_w = torch.stack(self.w.past_w)
        self._gates = torch.zeros(nb, self.batch, self.cfg.channels, dtype=self.dtype)
        self._skip_w = self.w.skip_w.view(nb, self.cfg.channels, -1)
        self._skip_b = (self.w.skip_b / nb).expand(nb, 1, -1)
        self.t = 0

    def set_static(self, skel: torch.Tensor, types: torch.Tensor):
        """Skeleton (B, n_skel) and type one-hot (B, n_types): their projection is cached."""
        with torch.inference_mode():
            self._static = torch.addmm(self.w.ctrl_b, torch.cat([skel, types], 1).to(self.dtype),
                                       self.w.ctrl_static_w)

    def step(self, x: torch.Tensor, traj: torch.Tensor, z: torch.Tensor | None = None) -> torch.Tensor:
        """x (B, n_x) frame t, traj (B, n_traj) control c^d_{t+1}, z (B, latent) the latent of
        a model with one (None: z = 0, the N(0, I) prior's mean: ``CCNet.prior_of``); returns
        the raw decoder output (B, n_out) for frame t+1 (split it with ``CCNet.split_output``)."""
        return self.head(self.trunk_step(x, traj), z, traj)

    def head(self, skip: torch.Tensor, z: torch.Tensor | None = None, traj: torch.Tensor | None = None) -> torch.Tensor:
        """``CCNet.head``: the raw output from the skip sum of :meth:`trunk_step` (and z; and
        the phase in the control ``traj``, with ``phase_harmonics``)."""
        plain = skip
        if z is not None and self.w.z_w is not None:
            skip = torch.addmm(skip, z.to(self.dtype), self.w.z_w)
        out = self._decode(skip, traj, slice(None))
        cols = self._without_z
        if z is not None and len(cols) and bool(z.any()):  # these from the skip sum alone (CCNet.head; z = 0 adds nothing)
            out[:, cols] = self._decode(plain, traj, cols)
        return out

    def _decode(self, skip, traj, columns: slice | torch.Tensor) -> torch.Tensor:
        h = skip.relu()
        out = torch.addmm(self.w.dec_b[columns], h, self.w.dec_w[:, columns])
        if self.w.phase_w is not None:
            out.addmm_(phase_basis(h, traj[:, -2:].to(self.dtype), self.cfg.phase_harmonics), self.w.phase_w[:, columns])
        return out

    def trunk_step(self, x: torch.Tensor, traj: torch.Tensor) -> torch.Tensor:
        """Advance one frame; returns the skip sum (B, S) before the decoder's ReLU."""
        w = self.w
        c = self.cfg.channels
        nb = len(self.cfg.dilations)
        r = self.hist.shape[0]
        past = self.hist[self._past_index[self.t % r], self._blocks]          # (nb, B, C), a copy
        cur = self.hist[self.t % r]                # block inputs of this frame are written here
        torch.addmm(w.enc_b, x, w.enc_w, out=cur[0]).relu_()
        cz = torch.addmm(self._static, traj, w.ctrl_traj_w)
        pre = torch.baddbmm(cz.view(self.batch, nb, 2 * c).transpose(0, 1), past, self._past_w)
        gates = self._gates
        for i in range(nb):
            z = pre[i].addmm_(cur[i], w.cur_w[i]).tanh_()
            a, b = z.chunk(2, dim=1)
            torch.addcmul(a, a, b, out=gates[i])   # 2 tanh(a) sigmoid(b); the 1/2 is in res/skip
            if i + 1 < nb:                          # the last block's residual feeds nothing
                torch.addmm(cur[i], gates[i], w.res_w[i], out=cur[i + 1])
        self.t += 1
        return torch.baddbmm(self._skip_b, gates, self._skip_w).sum(0)


class NumpyStepper:
    """The same incremental step on numpy arrays: for one character the per-call overhead of
    numpy is a fraction of torch's, and a frame is ~140 tiny calls. Same interface and results
    (to float rounding) as :class:`CCNetStepper`, with numpy arrays in and out."""

    def __init__(self, model: "CCNet", batch: int = 1):
        ref = CCNetStepper(model, batch)
        w = ref.w
        f = lambda t: t.detach().numpy().astype(np.float32).copy()  # noqa: E731
        self.cfg, self.batch = ref.cfg, batch
        self._without_z = ref.cfg.without_z_columns
        self.enc_w, self.enc_b = f(w.enc_w), f(w.enc_b)
        self.ctrl_static_w, self.ctrl_traj_w, self.ctrl_b = f(w.ctrl_static_w), f(w.ctrl_traj_w), f(w.ctrl_b)
        self.past_w = np.stack([f(x) for x in w.past_w])
        self.cur_w = [f(x) for x in w.cur_w]
        self.res_w = [f(x) for x in w.res_w]
        self.skip_w, self.skip_b, self.dec_w, self.dec_b = f(w.skip_w), f(w.skip_b), f(w.dec_w), f(w.dec_b)
        self.z_w = None if w.z_w is None else f(w.z_w)
        self.phase_w = None if w.phase_w is None else f(w.phase_w)
        # Why merged: as in trunk_step, a decode's cost is per numpy call, and the phase-functioned
        # decoder's basis (phase_basis) took a dozen calls per decode
        self._dec_all = self._merged_decoder(slice(None))
        self._dec_without_z = self._merged_decoder(self._without_z)
        self._hb = np.ones((batch, self.cfg.skip_channels + 1), np.float32)   # the decoder's input and a 1
        self._plain_blend = np.ones((batch, 1, 1), np.float32)
        self._static = None
        self.reset()

    def reset(self):
        c, dil = self.cfg.channels, self.cfg.dilations
        nb, r = len(dil), max(dil)
        # hist[t % R, i] holds block i's input at frame t; block i reads frame t - d_i (one
        # fancy-indexed read per frame, as CCNetStepper: not a stack of per-block rings)
        self.hist = np.zeros((r, nb, self.batch, c), dtype=np.float32)
        self._past_index = [np.array([(p - d) % r for d in dil]) for p in range(r)]
        self._blocks = np.arange(nb)
        self._g = np.zeros((self.batch, nb * c), dtype=np.float32)
        # Why fixed buffers and views made once: a frame is ~140 calls on arrays of a few dozen
        # numbers, where numpy's cost is per call and per new array, not per number
        self._pre = np.zeros((nb, self.batch, 2 * c), dtype=np.float32)
        self._tmp = np.zeros((self.batch, 2 * c), dtype=np.float32)
        self._views = [[(p[i], p[i + 1] if i + 1 < nb else None) for i in range(nb)] for p in self.hist]
        self._gates = [(z, z[:, :c], z[:, c:], self._g[:, i * c:(i + 1) * c]) for i, z in enumerate(self._pre)]
        self.t = 0

    def set_static(self, skel, types):
        st = np.concatenate([np.asarray(skel, np.float32), np.asarray(types, np.float32)], 1)
        self._static = st @ self.ctrl_static_w + self.ctrl_b

    def step(self, x: np.ndarray, traj: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
        return self.head(self.trunk_step(x, traj), z, traj)

    def head(self, skip: np.ndarray, z: np.ndarray | None = None, traj: np.ndarray | None = None) -> np.ndarray:
        """``CCNet.head`` on numpy arrays (``skip`` is overwritten)."""
        blend = self._blend(traj)
        # some columns from the skip sum alone (CCNet.head); z = 0 (the mean output) adds nothing to
        # the skip sum, so then the full decode's columns are that already
        cols = self._without_z
        plain = skip.copy() if z is not None and len(cols) and np.any(z) else None
        if z is not None and self.z_w is not None:
            skip += np.asarray(z, np.float32) @ self.z_w
        out = self._decode(skip, blend, self._dec_all, slice(None))
        if plain is not None:
            out[:, cols] = self._decode(plain, blend, self._dec_without_z, cols)
        return out

    def _merged_decoder(self, columns) -> np.ndarray:
        """(S + 1, J len(columns)): the decoder's weights (a zero row for the appended 1: the bias is
        added after the blend, :meth:`_decode`) beside the phase-functioned decoder's 2K weight sets, J = 2K + 1."""
        s = self.cfg.skip_channels
        plain = np.concatenate([self.dec_w, np.zeros((1, self.dec_w.shape[1]), np.float32)])[None]
        if self.phase_w is None:
            sets = plain
        else:
            sets = np.concatenate([plain, self.phase_w.reshape(-1, s + 1, plain.shape[-1])])
        return np.ascontiguousarray(sets[:, :, columns].transpose(1, 0, 2).reshape(s + 1, -1))

    def _blend(self, traj) -> np.ndarray:
        """(B, 1, J): the weights of the decoder's J weight sets, 1 and the phase's waves (the phase
        in the last two columns of the control ``traj``)."""
        if self.phase_w is None:
            return self._plain_blend
        waves = phase_waves(np.asarray(traj, np.float32)[:, -2:], self.cfg.phase_harmonics)
        return np.concatenate([self._plain_blend[:, 0], waves], 1)[:, None]

    def _decode(self, skip: np.ndarray, blend: np.ndarray, weights: np.ndarray, columns) -> np.ndarray:
        """The decoder's ``columns`` of the raw output: one matmul by the merged ``weights``
        (:meth:`_merged_decoder`), then the sets blended (the phase-functioned decoder's sum)."""
        hb = self._hb
        np.maximum(skip, 0, out=hb[:, :-1])
        y = hb @ weights
        out = np.matmul(blend, y.reshape(len(y), blend.shape[-1], -1))[:, 0]
        out += self.dec_b[columns]
        return out

    def trunk_step(self, x: np.ndarray, traj: np.ndarray) -> np.ndarray:
        """Advance one frame; returns the skip sum (B, S) before the decoder's ReLU."""
        # contiguous float32 whatever the caller holds (a row of a (B, T, n) array, a strided
        # view): numpy picks its matmul kernel by memory layout, and with numpy 2.4.6 the kernels
        # round differently (1e-7), so run() and the step API would part in the last digits
        x, traj = np.ascontiguousarray(x, np.float32), np.ascontiguousarray(traj, np.float32)
        nb, t, r = len(self._blocks), self.t, self.hist.shape[0]
        views = self._views[t % r]                 # block inputs of this frame are written here
        # the past first: with d_i = R, block i's past input sits where this frame's is written
        pre = np.matmul(self.hist[self._past_index[t % r], self._blocks], self.past_w, out=self._pre)  # (nb, B, 2C)
        cz = traj @ self.ctrl_traj_w
        cz += self._static
        pre += cz.reshape(self.batch, nb, 2 * self.cfg.channels).transpose(1, 0, 2)
        h0 = views[0][0]
        np.matmul(x, self.enc_w, out=h0)
        h0 += self.enc_b
        np.maximum(h0, 0, out=h0)
        tmp = self._tmp
        for (h, h_next), (z, a, b, g), cur_w, res_w in zip(views, self._gates, self.cur_w, self.res_w):
            z += np.matmul(h, cur_w, out=tmp)
            np.tanh(z, out=z)
            np.multiply(a, b, out=g)               # 2 tanh(a) sigmoid(b) (CCNetStepper): the 1/2 is in res/skip
            g += a
            if h_next is not None:                  # the last block's residual feeds nothing
                np.matmul(g, res_w, out=h_next)
                h_next += h
        self.t = t + 1
        skip = self._g @ self.skip_w
        skip += self.skip_b
        return skip

"""The MPT's forward pass for one sample as numba kernels over numpy weights.

The compiled attention phase (`temp_gym.planning._compiled_attention`) calls `forward_kernel`
once per MPT call, inside its numba loop; `temp_gym.models.fast_mpt.FastMPT` copies an `MPT`'s
weights into the arrays these kernels read (`FastMPT.kernel_weights`) and calls them from
Python. They live in the planning layer, which the compiled loop belongs to, and import no
model code: the weights come in as arrays. What they compute, and why it equals `MPT.forward`,
is `temp_gym.models.fast_mpt`'s docstring.
"""

from __future__ import annotations

import numba
import numpy as np

LAYER_NORM_EPS = 1e-5
"""``torch.nn.LayerNorm``'s default epsilon, which `MPT` uses everywhere."""

# ---- kernels ---------------------------------------------------------------------------------
# Activations are token-major, ``(tokens, features)``; weights are stored (in, out); every
# matrix product is a BLAS call ``x @ w`` (numba's ``np.dot``; OpenBLAS runs these sizes on the
# calling thread). For batch 1 and a few dozen tokens, BLAS beats hand-written loops even on
# the per-head attention products. The rest are loops written so that LLVM vectorizes them:
#
# * float32 throughout, as torch computes: numba promotes float32 mixed with a python float or
#   int to float64, so the constants are float32 scalars;
# * indices are plain loop counters over views (``reshape``, row slices), never ``i + offset``
#   (numba's negative-index wraparound would then stop the vectorizer);
# * the innermost loop runs over independent lanes (features, or the attention's query
#   columns), so no sum has to be reordered. Only LayerNorm's row sums are: `_layer_norm` alone
#   allows reassociation (``fastmath={"reassoc", "contract"}``; no assumption about NaN or
#   infinity), as BLAS reorders its sums anyway.
#
# Rows: 0 .. S-1 the constant prefix tokens (SEI, Goal, Start), S the output token, S+1 ..
# the path (oldest first). Attention does not depend on the order of its tokens, so this
# ordering, unlike torch's, only changes float rounding; the positional encodings are torch's.

_ZERO = np.float32(0.0)
_ONE = np.float32(1.0)
_EPS = np.float32(LAYER_NORM_EPS)
_LOG2E = np.float32(1.4426950408889634)
_LN2_HI = np.float32(0.693359375)  # ln 2 = _LN2_HI + _LN2_LO, the first exact in float32
_LN2_LO = np.float32(-2.12194440e-4)
_EXP_MIN = np.float32(-87.0)  # exp(-87) ~ 1.6e-38, still a normal float32
_EXP_P0 = np.float32(1.9875691500e-4)
_EXP_P1 = np.float32(1.3981999507e-3)
_EXP_P2 = np.float32(8.3334519073e-3)
_EXP_P3 = np.float32(4.1665795894e-2)
_EXP_P4 = np.float32(1.6666665459e-1)
_EXP_P5 = np.float32(5.0000001201e-1)


@numba.njit(cache=True, nogil=True)
def _exp_columns(scores):
    """``scores[:, i] = exp(scores[:, i] - max(scores[:, i]))`` in place; returns the sums.

    The softmax of each column, before the division by its sum (callers divide the far fewer
    mixed values instead). ``exp`` is Cephes' ``expf`` (a range reduction by ln 2, a degree-6
    polynomial, the power of two built from its bits) written out, so that the loop vectorizes:
    a libm call per element would cost more than the rest of the attention.
    """
    keys, queries = scores.shape
    top = scores[0].copy()
    for j in range(1, keys):
        for i in range(queries):
            top[i] = max(top[i], scores[j, i])
    bits = np.empty((keys, queries), np.int32)
    for j in range(keys):
        for i in range(queries):
            x = max(scores[j, i] - top[i], _EXP_MIN)  # <= 0
            n = np.floor(x * _LOG2E + np.float32(0.5))
            r = x - n * _LN2_HI - n * _LN2_LO
            p = ((((_EXP_P0 * r + _EXP_P1) * r + _EXP_P2) * r + _EXP_P3) * r + _EXP_P4) * r
            scores[j, i] = (p + _EXP_P5) * r * r + r + _ONE
            bits[j, i] = (np.int32(n) + np.int32(127)) << np.int32(23)
    powers = bits.view(np.float32)
    total = np.zeros(queries, np.float32)
    for j in range(keys):
        for i in range(queries):
            e = scores[j, i] * powers[j, i]
            scores[j, i] = e
            total[i] += e
    return total


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _layer_norm(x, weight, bias):
    """LayerNorm of each row of ``x`` (tokens, features), torch's formula; a fresh array."""
    count, width = x.shape
    inverse_width = _ONE / np.float32(width)
    out = np.empty((count, width), np.float32)
    for i in range(count):
        mean = _ZERO
        for c in range(width):
            mean += x[i, c]
        mean *= inverse_width
        var = _ZERO
        for c in range(width):
            diff = x[i, c] - mean
            var += diff * diff
        scale = _ONE / np.sqrt(var * inverse_width + _EPS)
        for c in range(width):
            out[i, c] = (x[i, c] - mean) * scale * weight[c] + bias[c]
    return out


@numba.njit(cache=True, nogil=True)
def _add_bias(x, bias, relu):
    """``x[i] += bias`` for each row, in place; then ``max(., 0)`` with ``relu``."""
    rows, cols = x.shape
    for i in range(rows):
        for c in range(cols):
            v = x[i, c] + bias[c]
            x[i, c] = max(v, _ZERO) if relu else v


@numba.njit(cache=True, nogil=True)
def _attend_all(qkv, num_heads):
    """Every token's attention output ``(T, width)``, heads side by side, from ``qkv`` (T, 3w).

    The queries come scaled by 1/sqrt(head_dim) (`FastMPT` folds it into the weights). Each
    head's queries, keys and values are copied out contiguously for BLAS; its scores are kept
    (keys, queries), so that the softmax runs over independent columns.
    """
    tokens = qkv.shape[0]
    width = qkv.shape[1] // 3
    head_dim = width // num_heads
    split = qkv.reshape(tokens, 3, num_heads, head_dim)
    heads = np.empty((3, num_heads, tokens, head_dim), np.float32)
    for part in range(3):
        for h in range(num_heads):
            for i in range(tokens):
                for k in range(head_dim):
                    heads[part, h, i, k] = split[i, part, h, k]
    mixed = np.empty((tokens, num_heads, head_dim), np.float32)
    for h in range(num_heads):
        scores = np.dot(heads[1, h], heads[0, h].T)  # (keys, queries)
        total = _exp_columns(scores)
        mixed_head = np.dot(scores.T, heads[2, h])  # (queries, head_dim), unnormalized
        for i in range(tokens):
            inverse = _ONE / total[i]
            for k in range(head_dim):
                mixed[i, h, k] = mixed_head[i, k] * inverse
    return mixed.reshape(tokens, width)


@numba.njit(cache=True, nogil=True)
def _attend_one(query, key, value, num_heads):
    """One token's attention output ``(width,)``: its ``query`` over ``key``/``value`` (T, w).

    The query comes scaled, as in `_attend_all`. The heads share two matrix products through a
    block-diagonal query matrix (row h holds head h's part of the query, zeros elsewhere).
    """
    width = query.shape[0]
    head_dim = width // num_heads
    split = query.reshape(num_heads, head_dim)
    blocks = np.zeros((num_heads, num_heads, head_dim), np.float32)
    for h in range(num_heads):
        for k in range(head_dim):
            blocks[h, h, k] = split[h, k]
    scores = np.dot(key, blocks.reshape(num_heads, width).T)  # (keys, heads)
    total = _exp_columns(scores)
    every = np.dot(scores.T, value).reshape(num_heads, num_heads, head_dim)
    mixed = np.empty((num_heads, head_dim), np.float32)
    for h in range(num_heads):
        inverse = _ONE / total[h]
        for k in range(head_dim):
            mixed[h, k] = every[h, h, k] * inverse
    return mixed.reshape(width)


@numba.njit(cache=True, nogil=True)
def _linear_rows(x, weight, bias, relu):
    """``x @ weight + bias`` (then ``max(., 0)`` with ``relu``), a fresh array."""
    out = np.dot(x, weight)
    _add_bias(out, bias, relu)
    return out


@numba.njit(cache=True, nogil=True)
def prefix_kernel(sei, task, start, embeddings, position, ln, wqkv, bqkv):
    """The prefix tokens ``z`` (S, w) of SEI, Goal and Start, and layer 0's qkv ``(S, 3w)``.

    ``task`` is the goal and the goal radius; ``embeddings`` holds the three embeddings'
    weights (in, out) and biases; ``position`` the prefix positions after the output token's.
    """
    sei_w, sei_b, goal_w, goal_b, start_w, start_b = embeddings
    count = sei.shape[0]
    z = np.empty((count + 2, sei_w.shape[1]), np.float32)
    z[:count] = np.dot(sei, sei_w)
    _add_bias(z[:count], sei_b, False)
    z[count] = np.dot(task, goal_w) + goal_b
    z[count + 1] = np.dot(start, start_w) + start_b
    z += position
    qkv = np.dot(_layer_norm(z, ln[0, 0], ln[0, 1]), wqkv[0])
    _add_bias(qkv, bqkv[0], False)
    return z, qkv


@numba.njit(cache=True, nogil=True)
def task_prefix_kernel(sei, start, goal, bounds, ratio, embeddings, position, ln, wqkv, bqkv):
    """The task as the model reads it, and `prefix_kernel`'s tokens of it, in one call.

    ``start`` and ``goal`` are ``(d,)`` float64 world states, ``bounds`` ``(2, d)``, ``ratio``
    the goal radius ratio (`temp_gym.worlds.normalization.goal_radius_ratio`). Returns the
    normalized goal, the ratio and the normalized start as float32 arrays (``(d,)``, ``(1,)``,
    ``(d,)``: `normalize`'s float64 arithmetic, rounded once), then ``z`` and ``qkv``. A policy
    resets to a new problem at the start of every plan, and these numpy steps, one call each,
    cost several times this kernel there.
    """
    dim = start.shape[0]
    task = np.empty(dim + 1, np.float32)
    normalized_start = np.empty(dim, np.float32)
    for k in range(dim):
        low = bounds[0, k]
        span = bounds[1, k] - low
        task[k] = 2.0 * (goal[k] - low) / span - 1.0
        normalized_start[k] = 2.0 * (start[k] - low) / span - 1.0
    task[dim] = ratio
    z, qkv = prefix_kernel(sei, task, normalized_start, embeddings, position, ln, wqkv, bqkv)
    return task[:dim].copy(), task[dim:].copy(), normalized_start, z, qkv


@numba.njit(cache=True, nogil=True)
def forward_kernel(
    path,
    length,
    goal,
    prefix_z,
    prefix_qkv,
    out_bias,
    current_w,
    path_w,
    path_position,
    ln,
    wqkv,
    bqkv,
    w_split,
    wo,
    bo,
    w1,
    b1,
    w2,
    b2,
    final_ln,
    head_w,
    head_b,
    num_heads,
    offset_scale,
    out,
):
    """One MPT forward pass for one sample; writes its chunk to ``out`` (see `FastMPT.predict`).

    Shapes (w: token width, S: prefix tokens, M layers, d), weights (in, out): ``prefix_z``
    (S, w), ``prefix_qkv`` (S, 3w), ``out_bias`` (w,), ``current_w`` (2d, w), ``path_w``
    (d, w), ``path_position`` (L, w) (path bias included), ``ln`` (M, 4, w), ``wqkv``
    (M, w, 3w), ``bqkv`` (M, 3w), ``w_split`` (M, 3, w, w) (wqkv's query, key, value parts),
    ``wo`` (M, w, w) etc., ``final_ln`` (2, w), ``head_w`` (w, k d), ``out`` (k, d) for a
    chunk of k samples.
    ``offset_scale > 0`` selects the ``offset`` prediction, 0 the ``absolute`` one.
    """
    prefix, width = prefix_z.shape
    dim = path.shape[1]
    num_layers = wqkv.shape[0]
    tokens = prefix + 1 + length
    current = path[length - 1]

    # Embeddings: the constant prefix; the output token from x_c and goal - x_c; the path,
    # whose positions count back from the newest node.
    z = np.empty((tokens, width), np.float32)
    z[:prefix] = prefix_z
    token = out_bias.copy()
    for k in range(dim):
        x = current[k]
        g = goal[k] - x
        for c in range(width):
            token[c] += current_w[k, c] * x + current_w[dim + k, c] * g
    z[prefix] = token
    rows = z[prefix + 1 :]
    positions = path_position[:length][::-1]
    for r in range(length):
        for c in range(width):
            rows[r, c] = positions[r, c]
        for k in range(dim):
            x = path[r, k]
            for c in range(width):
                rows[r, c] += x * path_w[k, c]

    qkv = np.empty((tokens, 3 * width), np.float32)
    for layer in range(num_layers):
        first = prefix if layer == 0 else 0  # layer 0's prefix rows are cached
        normed = _layer_norm(z[first:], ln[layer, 0], ln[layer, 1])
        if layer < num_layers - 1:
            np.dot(normed, wqkv[layer], qkv[first:])
            _add_bias(qkv[first:], bqkv[layer], False)
            if layer == 0:
                qkv[:prefix] = prefix_qkv
            z += _linear_rows(_attend_all(qkv, num_heads), wo[layer], bo[layer], False)
            hidden = _linear_rows(
                _layer_norm(z, ln[layer, 2], ln[layer, 3]), w1[layer], b1[layer], True
            )
            z += _linear_rows(hidden, w2[layer], b2[layer], False)
        else:
            # Only the output token is read after the last layer: keys and values of every
            # token, but the query, attention and FFN of the output token alone.
            key = np.empty((tokens, width), np.float32)
            value = np.empty((tokens, width), np.float32)
            np.dot(normed, w_split[layer, 1], key[first:])
            np.dot(normed, w_split[layer, 2], value[first:])
            _add_bias(key[first:], bqkv[layer, width : 2 * width], False)
            _add_bias(value[first:], bqkv[layer, 2 * width :], False)
            if layer == 0:
                key[:prefix] = prefix_qkv[:, width : 2 * width]
                value[:prefix] = prefix_qkv[:, 2 * width :]
            query = np.dot(normed[prefix - first], w_split[layer, 0])
            query += bqkv[layer, :width]
            token = z[prefix] + np.dot(_attend_one(query, key, value, num_heads), wo[layer])
            token += bo[layer]
            normed_token = _layer_norm(token.reshape(1, width), ln[layer, 2], ln[layer, 3])
            hidden = np.dot(normed_token[0], w1[layer]) + b1[layer]
            hidden = np.maximum(hidden, _ZERO)
            token += np.dot(hidden, w2[layer]) + b2[layer]

    normed_token = _layer_norm(token.reshape(1, width), final_ln[0], final_ln[1])[0]
    for row in range(out.shape[0]):  # the chunk: each row continues from the previous one
        for j in range(dim):
            column = row * dim + j
            v = head_b[column]
            for c in range(width):
                v += normed_token[c] * head_w[c, column]
            v = np.tanh(v)
            if offset_scale > 0:  # torch.clamp: NaN stays NaN
                v = (current[j] if row == 0 else out[row - 1, j]) + np.float32(offset_scale) * v
                if v < -_ONE:
                    v = -_ONE
                elif v > _ONE:
                    v = _ONE
            out[row, j] = v


__all__ = ["LAYER_NORM_EPS", "forward_kernel", "prefix_kernel", "task_prefix_kernel"]

import pytest
import torch

from temp_gym.models.loss import TEMPLoss
from temp_gym.models.temp import TEMPModel


@pytest.mark.parametrize(
    ("robot", "grid", "dim"),
    [("point2d", (16, 16), 2), ("point3d", (8, 8, 8), 3), ("kuka_iiwa14", (8, 8, 8), 7)],
)
def test_shapes(robot, grid, dim, make_batch, small_config):
    model = TEMPModel(robot, encoding_resolution=grid[0], max_path_length=16, **small_config)
    batch = make_batch(5, dim=dim, grid=grid, length=16)
    out = model(batch, need_weights=True)
    assert out["sample"].shape == (5, dim)
    assert out["recons_logits"].shape == (5, *grid)
    assert out["sample"].abs().max() <= 1.0
    tokens = small_config["num_sei_tokens"] + 3 + int(batch["path_length"].max())
    assert out["attention"].shape == (
        5,
        small_config["num_layers"],
        small_config["num_heads"],
        tokens,
        tokens,
    )


def test_attention_sums_to_one_over_unmasked_keys(small_model, make_batch):
    batch = make_batch(6, length=16, seed=1)
    weights = small_model(batch, need_weights=True)["attention"]
    torch.testing.assert_close(weights.sum(-1), torch.ones(weights.shape[:-1]))
    prefix = small_model.mpt.num_prefix
    rows = weights.shape[-1] - prefix
    padded = torch.arange(rows)[None, :] >= batch["path_length"].reshape(-1, 1)
    padded_mass = weights[..., prefix:] * padded[:, None, None, None, :]
    assert float(padded_mass.detach().abs().max()) == 0.0


def test_padding_does_not_change_the_prediction(small_model, make_batch):
    small_model.eval()
    batch = make_batch(4, length=16, seed=2)
    with torch.no_grad():
        full = small_model(batch)["sample"]
        alone = [
            small_model({key: value[i : i + 1] for key, value in batch.items()})["sample"]
            for i in range(4)
        ]
    torch.testing.assert_close(full, torch.cat(alone), atol=1e-5, rtol=1e-5)


def test_fused_and_explicit_attention_agree(small_model, make_batch):
    small_model.eval()
    batch = make_batch(4, length=16, seed=3)
    with torch.no_grad():
        fused = small_model(batch)["sample"]
        explicit = small_model(batch, need_weights=True)["sample"]
    torch.testing.assert_close(fused, explicit, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("term", ["recons", "semantic"])
def test_gradients_reach_eise_through_each_term(small_model, term, make_batch):
    batch = make_batch(8, seed=4)
    out = small_model(batch)
    terms = TEMPLoss()(out["recons_logits"], batch["occupancy"], out["sample"], batch["target"])
    terms[term].backward()
    first_layer = small_model.eise.encoder[0].weight.grad
    assert first_layer is not None and float(first_layer.abs().sum()) > 0


def test_occupancy_index_shares_the_encoding(small_model, make_batch):
    small_model.eval()
    batch = make_batch(4, seed=5)
    batch["occupancy"][2:] = batch["occupancy"][1]
    shared = dict(
        batch, occupancy=batch["occupancy"][:2], occupancy_index=torch.tensor([0, 1, 1, 1])
    )
    with torch.no_grad():
        torch.testing.assert_close(small_model(batch)["sample"], small_model(shared)["sample"])


def test_overfits_64_samples(make_batch, small_config):
    torch.manual_seed(0)
    model = TEMPModel("point2d", encoding_resolution=16, max_path_length=16, **small_config)
    batch = make_batch(64, seed=6)
    loss_module = TEMPLoss(recons_weight=1.0, semantic_weight=1.0)
    optimizer = torch.optim.Adam(model.parameters(), lr=2e-3)

    def loss() -> torch.Tensor:
        out = model(batch)
        return loss_module(out["recons_logits"], batch["occupancy"], out["sample"], batch["target"])

    with torch.no_grad():
        initial = float(loss()["loss"])
    for _ in range(300):
        optimizer.zero_grad()
        loss()["loss"].backward()
        optimizer.step()
    with torch.no_grad():
        assert float(loss()["loss"]) < initial / 10


def test_unknown_model_key_is_an_error():
    with pytest.raises(ValueError, match=r"unknown key model\.token_dims \(did you mean"):
        TEMPModel("point2d", 16, 16, token_dims=3)
    with pytest.raises(ValueError, match="model.num_layers: expected an integer, got 'two'"):
        TEMPModel("point2d", 16, 16, num_layers="two")


def test_chunk_loss_is_a_per_sample_mean_over_the_valid_entries():
    loss = TEMPLoss(recons_weight=0.0, semantic_weight=1.0)
    logits, grid = torch.zeros(2, 4, 4), torch.zeros(2, 4, 4)
    sample = torch.zeros(2, 3, 2)
    target = torch.tensor(
        [[[1.0, 1.0], [2.0, 2.0], [9.0, 9.0]], [[3.0, 3.0], [9.0, 9.0], [9.0, 9.0]]]
    )
    mask = torch.tensor([[True, True, False], [True, False, False]])
    terms = loss(logits, grid, sample, target, None, mask)
    assert float(terms["semantic"]) == pytest.approx(((1 + 4) / 2 + 9) / 2)
    # One entry per sample: the plain MSE.
    single = loss(logits, grid, sample[:, :1], target[:, :1])
    assert float(single["semantic"]) == pytest.approx(float(torch.mean(target[:, 0] ** 2)))
    with pytest.raises(ValueError, match="shapes"):
        loss(logits, grid, sample, target[:, :2], None, mask)

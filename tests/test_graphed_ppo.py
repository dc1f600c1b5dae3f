"""GraphedPPO (warpdyn.envs.rsl_rl) against rsl-rl's PPO: the same actions, returns, advantages and parameters after
updates, from the same initial models, transitions and random draws; on a GPU, its CUDA graphs against its eager
code."""

import copy
import types
from itertools import chain

import pytest
import torch
import warp as wp
from rsl_rl.algorithms import PPO
from tensordict import TensorDict

from warpdyn.envs.rsl_rl import GraphedPPO

N, OBS, ACTIONS, STEPS = 16, 5, 3, 4
DISTRIBUTIONS = {
    "gaussian": dict(class_name="GaussianDistribution", init_std=1.0),
    "beta": dict(class_name="BetaDistribution", action_range=(-1.0, 1.0)),
}


def _algorithm(cls, device: str, distribution: str, epochs: int, mini_batches: int, critic_group: bool = False, multi_gpu: dict | None = None, **settings):
    """An rsl-rl algorithm of class cls on small MLPs, its initial parameters from seed 0; `settings`: PPO's others;
    `multi_gpu`: rsl-rl's multi_gpu configuration (a process group initialised)."""
    torch.manual_seed(0)
    groups = {"policy": torch.zeros(N, OBS, device=device)}
    if critic_group:
        groups["critic"] = torch.zeros(N, OBS + 2, device=device)
    obs = TensorDict(groups, batch_size=[N], device=device)
    mlp = dict(hidden_dims=[32, 16], activation="elu", obs_normalization=True)
    cfg = {
        "num_steps_per_env": STEPS,
        "obs_groups": {"actor": ["policy"], "critic": ["critic" if critic_group else "policy"]},
        "algorithm": dict(class_name=cls, learning_rate=1e-3, num_learning_epochs=epochs, num_mini_batches=mini_batches, clip_param=0.2,
                          gamma=0.97, lam=0.95, value_loss_coef=1.0, entropy_coef=0.01, max_grad_norm=1.0, schedule="adaptive", desired_kl=0.01)
                     | settings,  # fmt: skip
        "actor": dict(class_name="MLPModel", distribution_cfg=dict(DISTRIBUTIONS[distribution]), **mlp),
        "critic": dict(class_name="MLPModel", **mlp),
        "multi_gpu": multi_gpu,
    }
    env = types.SimpleNamespace(num_envs=N, num_actions=ACTIONS)
    alg = PPO.construct_algorithm(obs, env, cfg, device)
    alg.train_mode()
    return alg


def _observations(step: int, device: str, critic_group: bool) -> TensorDict:
    g = torch.Generator().manual_seed(1000 + step)
    groups = {"policy": 2.0 * torch.randn(N, OBS, generator=g) + 1.0}
    if critic_group:
        groups["critic"] = torch.randn(N, OBS + 2, generator=g)
    return TensorDict({k: v.to(device) for k, v in groups.items()}, batch_size=[N], device=device)


def _iteration(alg, iteration: int, device: str, critic_group: bool) -> dict:
    """One PPO iteration of fixed observations, rewards and dones, the random draws seeded: (actions, returns,
    advantages, losses)."""
    g = torch.Generator().manual_seed(iteration)
    actions = []
    with torch.inference_mode():
        for t in range(STEPS):
            obs = _observations(STEPS * iteration + t, device, critic_group)
            torch.manual_seed(100 * iteration + t)
            actions.append(alg.act(obs).clone())
            rewards = torch.randn(N, generator=g).to(device)
            dones = (torch.rand(N, generator=g) < 0.2).to(device, torch.long)
            time_outs = (torch.rand(N, generator=g) < 0.5).to(device) & dones.bool()
            alg.process_env_step(obs, rewards, dones, {"time_outs": time_outs})
        alg.compute_returns(_observations(STEPS * iteration + STEPS, device, critic_group))
    returns, advantages = alg.storage.returns.clone(), alg.storage.advantages.clone()
    torch.manual_seed(7 + iteration)
    losses = alg.update()
    return {"actions": torch.stack(actions), "returns": returns, "advantages": advantages, "losses": losses}


def _parameters(alg) -> torch.Tensor:
    state = alg.save()
    return torch.cat([t.reshape(-1).float() for t in (*state["actor_state_dict"].values(), *state["critic_state_dict"].values())])


@pytest.fixture
def permutation_as_graphed(monkeypatch):
    """rsl-rl's mini-batch shuffle drawn as GraphedPPO draws it (the order of uniform draws), so both shuffle alike."""
    monkeypatch.setattr(torch, "randperm", lambda n, requires_grad=False, device=None: torch.argsort(torch.rand(n, device=device)))


@pytest.mark.parametrize("distribution", sorted(DISTRIBUTIONS))
@pytest.mark.parametrize("mini_batches,critic_group", [(1, False), (4, True)])
def test_graphed_ppo_equals_rsl_rl_ppo(distribution, mini_batches, critic_group, permutation_as_graphed):
    ref = _algorithm(PPO, "cpu", distribution, epochs=3, mini_batches=mini_batches, critic_group=critic_group)
    alg = _algorithm(GraphedPPO, "cpu", distribution, epochs=3, mini_batches=mini_batches, critic_group=critic_group)
    assert torch.equal(_parameters(ref), _parameters(alg))
    start = _parameters(ref)
    for it in range(3):
        a, b = _iteration(ref, it, "cpu", critic_group), _iteration(alg, it, "cpu", critic_group)
        torch.testing.assert_close(b["actions"], a["actions"], rtol=1e-5, atol=1e-6)
        torch.testing.assert_close(b["returns"], a["returns"], rtol=1e-6, atol=1e-6)
        torch.testing.assert_close(b["advantages"], a["advantages"], rtol=1e-5, atol=1e-5)
        for key in ("value", "surrogate", "entropy"):
            assert b["losses"][key] == pytest.approx(a["losses"][key], rel=1e-4, abs=1e-6), key
        assert alg.learning_rate == pytest.approx(ref.learning_rate, rel=1e-6)
        torch.testing.assert_close(_parameters(alg), _parameters(ref), rtol=1e-4, atol=1e-5)
    assert (_parameters(alg) - start).abs().max() > 1e-3  # the updates moved the models
    assert ref.learning_rate != 1e-3  # the adaptive schedule acted


@pytest.mark.parametrize("settings", [dict(normalize_advantage_per_mini_batch=True), dict(schedule="fixed"), dict(use_clipped_value_loss=False)], ids=str)
def test_graphed_ppo_equals_rsl_rl_ppo_in_its_other_settings(settings, permutation_as_graphed):
    """Advantages normalised per mini-batch, a fixed learning rate, the unclipped value loss: as rsl-rl's PPO."""
    ref = _algorithm(PPO, "cpu", "gaussian", epochs=2, mini_batches=4, **settings)
    alg = _algorithm(GraphedPPO, "cpu", "gaussian", epochs=2, mini_batches=4, **settings)
    for it in range(2):
        a, b = _iteration(ref, it, "cpu", False), _iteration(alg, it, "cpu", False)
        for key in ("value", "surrogate", "entropy"):
            assert b["losses"][key] == pytest.approx(a["losses"][key], rel=1e-4, abs=1e-6), key
        torch.testing.assert_close(_parameters(alg), _parameters(ref), rtol=1e-4, atol=1e-5)
    assert alg.learning_rate == pytest.approx(ref.learning_rate, rel=1e-6)
    assert (ref.learning_rate == 1e-3) == (settings.get("schedule") == "fixed")


def test_a_checkpoint_resumes_the_same_training_and_loads_into_rsl_rl():
    """A GraphedPPO saved after an iteration and loaded into another resumes as the first continues (the adaptive
    learning rate, a tensor Adam reads, and Adam's moments restored); rsl-rl's PPO loads it with a number for its
    learning rate."""
    alg = _algorithm(GraphedPPO, "cpu", "gaussian", epochs=3, mini_batches=2)
    _iteration(alg, 0, "cpu", False)
    saved = copy.deepcopy(alg.save())
    resumed = _algorithm(GraphedPPO, "cpu", "gaussian", epochs=3, mini_batches=2)
    resumed.load(saved, None, strict=True)
    assert resumed.optimizer.param_groups[0]["lr"] is resumed._lr and resumed.learning_rate == pytest.approx(alg.learning_rate)
    assert alg.learning_rate != 1e-3  # (the schedule moved it)
    for it in (1, 2):
        _iteration(alg, it, "cpu", False)
        _iteration(resumed, it, "cpu", False)
        torch.testing.assert_close(_parameters(resumed), _parameters(alg), rtol=0, atol=0)
    ref = _algorithm(PPO, "cpu", "gaussian", epochs=3, mini_batches=2)
    ref.load(saved, None, strict=True)
    assert type(ref.learning_rate) is float and ref.learning_rate == pytest.approx(float(saved["optimizer_state_dict"]["param_groups"][0]["lr"]))


def _two_ranks(rank: int, rendezvous: str, out: str) -> None:
    """One of two gloo ranks: GraphedPPO's gradient averaging alone (rank r's gradients all r + 1); then GraphedPPO
    and rsl-rl's PPO, each from its own random initial parameters made rank 0's (broadcast), through three
    iterations of this rank's own observations, rewards and draws; saves the averaged gradients, and both's
    parameters before the broadcast and after each iteration."""
    torch.distributed.init_process_group("gloo", init_method=rendezvous, rank=rank, world_size=2)
    torch.randperm = lambda n, requires_grad=False, device=None: torch.argsort(torch.rand(n, device=device))  # GraphedPPO's shuffle
    multi_gpu = {"global_rank": rank, "local_rank": rank, "world_size": 2}
    algs, saved = {}, {}
    for name, cls in (("ppo", PPO), ("graphed", GraphedPPO)):
        alg = _algorithm(cls, "cpu", "gaussian", epochs=2, mini_batches=2, multi_gpu=multi_gpu)
        torch.manual_seed(rank)
        torch.nn.init.normal_(alg.actor.mlp[0].weight)  # rank-dependent until the broadcast
        saved[f"{name} before"] = _parameters(alg)
        alg.broadcast_parameters()
        algs[name] = alg
        saved[name] = [_parameters(alg)]
    params = list(chain(algs["graphed"].actor.parameters(), algs["graphed"].critic.parameters()))
    for p in params:
        p.grad = torch.full_like(p, rank + 1.0)
    algs["graphed"]._average_gradients()
    saved["averaged"] = torch.cat([p.grad.reshape(-1) for p in params])
    for p in params:
        p.grad = None
    for it in range(3):
        for name, alg in algs.items():
            _iteration(alg, 10 * rank + it, "cpu", False)
            saved[name].append(_parameters(alg))
    saved["learning_rate"] = [algs["ppo"].learning_rate, algs["graphed"].learning_rate]
    torch.save(saved, f"{out}/rank{rank}.pt")
    torch.distributed.destroy_process_group()


def test_two_ranks_average_as_rsl_rl_ppo(tmp_path):
    """Under a process group (two gloo ranks on the CPU, each its own data): GraphedPPO's averaged gradients are the
    ranks' mean; its parameters equal rsl-rl's PPO's on each rank after each iteration (the gradients, KL and
    learning rate averaged alike), and the two ranks hold the same parameters, which differed before the broadcast
    (without the averaging they part after the first update). NCCL inside CUDA graphs: on two GPUs only (the
    example's runs, benchmarks/RESULTS.md)."""
    torch.multiprocessing.spawn(_two_ranks, args=(f"file://{tmp_path}/rendezvous", str(tmp_path)), nprocs=2, join=True)
    ranks = [torch.load(tmp_path / f"rank{r}.pt") for r in range(2)]
    for saved in ranks:
        assert torch.equal(saved["averaged"], torch.full_like(saved["averaged"], 1.5))  # (1 + 2) / 2 on both ranks
    for name in ("graphed", "ppo"):
        assert (ranks[0][f"{name} before"] - ranks[1][f"{name} before"]).abs().max() > 0.1  # the broadcast's work
    for saved in ranks:
        for graphed, ppo in zip(saved["graphed"], saved["ppo"]):
            torch.testing.assert_close(graphed, ppo, rtol=1e-4, atol=1e-5)
        assert saved["learning_rate"][1] == pytest.approx(saved["learning_rate"][0], rel=1e-6)
    for name in ("graphed", "ppo"):
        for first, second in zip(ranks[0][name], ranks[1][name]):
            torch.testing.assert_close(second, first, rtol=0, atol=0)
        assert (ranks[0][name][-1] - ranks[0][name][0]).abs().max() > 1e-3  # the updates moved the models
    assert ranks[0]["learning_rate"][0] == ranks[1]["learning_rate"][0] != 1e-3  # rank 0's adaptive rate on both


def test_graphed_ppo_refuses_what_it_does_not_run():
    actor = types.SimpleNamespace(is_recurrent=True)
    with pytest.raises(ValueError, match="feed-forward"):
        GraphedPPO(actor, actor, None)
    critic = types.SimpleNamespace(is_recurrent=False)
    with pytest.raises(ValueError, match="rnd_cfg"):
        GraphedPPO(critic, critic, None, rnd_cfg={"weight": 1.0})
    with pytest.raises(ValueError, match="optimises with Adam.*'sgd'"):
        GraphedPPO(critic, critic, None, optimizer="sgd")
    alg = _algorithm(GraphedPPO, "cpu", "gaussian", epochs=1, mini_batches=1)
    with pytest.raises(ValueError, match="instead of torch.compile; got torch_compile_mode='default'"):
        alg.compile("default")
    alg.compile(None)  # (rsl-rl's construct_algorithm calls it so)


@pytest.mark.skipif(not wp.get_device().is_cuda, reason="CUDA graphs: the tests' device is not a GPU")
@pytest.mark.parametrize("distribution", sorted(DISTRIBUTIONS))
def test_graphs_replay_the_eager_update(distribution):
    """Its graphs (the second iteration captures, the third replays) against its eager code on the same GPU, the
    transitions copied from the eager run (sampling draws differ between a graph and eager code); one mini-batch, whose
    shuffle does not change the update."""
    eager = _algorithm(GraphedPPO, "cuda", distribution, epochs=3, mini_batches=1)
    eager._capture = False
    graphed = _algorithm(GraphedPPO, "cuda", distribution, epochs=3, mini_batches=1)
    for it in range(4):
        with torch.inference_mode():
            for t in range(STEPS):
                obs = _observations(STEPS * it + t, "cuda", False)
                actions = graphed.act(obs)
                torch.testing.assert_close(graphed.transition.values, eager.critic(obs), rtol=1e-5, atol=1e-6)
                eager.actor(obs, stochastic_output=True)
                for p, q in zip(graphed.transition.distribution_params, eager.actor.output_distribution_params):
                    torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)
                torch.testing.assert_close(graphed.transition.actions_log_prob, eager.actor.get_output_log_prob(actions), rtol=1e-4, atol=1e-5)
                graphed.transition.rewards, graphed.transition.dones = torch.zeros(N, device="cuda"), torch.zeros(N, device="cuda")
                graphed.storage.add_transition(graphed.transition)  # the rollout's tensors are copied from the eager run below
                graphed.transition.clear()
        a = _iteration(eager, it, "cuda", False)
        st, ref = graphed.storage, eager.storage
        with torch.inference_mode():  # (the storage's distribution parameters were made there)
            for name in ("actions", "rewards", "dones", "values", "actions_log_prob"):
                getattr(st, name).copy_(getattr(ref, name))
            for p, q in zip(st.distribution_params, ref.distribution_params):
                p.copy_(q)
            st.observations.update_(ref.observations)
            graphed.compute_returns(_observations(STEPS * it + STEPS, "cuda", False))
        torch.testing.assert_close(st.advantages, a["advantages"], rtol=1e-5, atol=1e-5)
        graphed.update()
        torch.testing.assert_close(_parameters(graphed), _parameters(eager), rtol=1e-4, atol=1e-5)
    assert set(graphed._graphs) == {"act", "returns", "update"}

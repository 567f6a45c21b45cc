"""Every hyper-parameter's one home: a typed config per stage, validated when it is built.

Each field is declared with ``setting(default, doc, ...)`` (the machinery: ``settings.py``): the doc is the field's
one-line comment (and what ``lwail defaults STAGE`` prints beside it), the bounds are checked on construction, so a
config holding a bad value cannot exist and nothing is written before the check. A config is recorded whole in the
manifest of the artifact it produced; any field can be overridden from the CLI with ``--set section.field=value``
(e.g. ``--set td3.actor_lr=1e-4``). Defaults and their sources: ``docs/algorithm.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import LwailError
# the machinery, re-exported: callers build, record and override configs as cfg.to_dict, cfg.with_overrides, ...
from .settings import (  # noqa: F401
    Validated, describe, from_dict, recorded_by_0_3, resume_may_change, section, setting, to_dict, with_overrides,
)

MAX_STEPS = 100_000_000  # a budget past this is a typo, not a run (1M steps take ~1.5 h here)
LAYER_NORMS = ("none", "after", "before")  # where φ, ψ and T normalise: nets.StackedMLP
POLICY_NETWORKS = ("actor", "target", "average")  # TD3's online actor, its target actor, a slower average (train.average_tau)
MAX_BUFFER = 10_000_000  # replay rows: ~1 GiB per 10M rows of a 11-dim task, far more for Ant
METHODS = ("lwail", "gaifo", "pwil", "bco", "opolo", "difo")  # the imitation methods, one entry each in methods.METHODS (its test checks both agree)
ADVERSARIAL = ("lwail", "gaifo", "opolo", "difo")  # the methods whose adversary trains on the update_every schedule (imitation.AdversarialReward)


# ------------------------------------------------------------------------------ shared sections
@dataclass(frozen=True)
class TD3Config(Validated):
    hidden: tuple[int, ...] = setting((256, 256), "hidden widths of the actor and of each twin critic", low=1, high=4096)
    actor_lr: float = setting(3e-4, "actor Adam learning rate", low=1e-7, high=1.0)
    critic_lr: float = setting(1e-3, "twin-critic Adam learning rate", low=1e-7, high=1.0)
    batch_size: int = setting(256, "transitions per TD3 update", low=1, high=65_536)
    gamma: float = setting(0.99, "discount factor", low=0.0, below=1.0)
    tau: float = setting(0.005, "Polyak rate of the target networks", low=0.0, high=1.0)
    policy_delay: int = setting(2, "critic updates per actor (and target) update", low=1, high=1000)
    target_noise: float = setting(0.2, "target-policy smoothing noise, times the action scale", low=0.0, high=10.0)
    target_noise_clip: float = setting(0.5, "clip of that noise, times the action scale", low=0.0, high=10.0)
    exploration_noise: float = setting(0.1, "Gaussian exploration noise, times the action scale", low=0.0, high=10.0)
    buffer_size: int = setting(1_000_000, "replay capacity (capped at the run's steps)", low=1, high=MAX_BUFFER)
    random_steps: int = setting(10_000, "uniformly random actions before the actor acts", low=0, high=MAX_STEPS)
    learning_starts: int = setting(4_000, "env steps before the first gradient update", low=1, high=MAX_STEPS)

    def check(self) -> None:
        starts, batch = vars(self)["learning_starts"], vars(self)["batch_size"]
        if starts < batch:
            raise LwailError(f"td3.learning_starts ({starts}) must be at least td3.batch_size ({batch})")


@dataclass(frozen=True)
class TrainConfig(Validated):
    """The schedule of an online TD3 run (an expert on the true reward, or LWAIL)."""

    steps: int = setting(1_000_000, "environment steps, one TD3 update each", low=1, high=MAX_STEPS, resume_may_change=True)
    eval_every: int = setting(10_000, "evaluate the deterministic actor every this many env steps", low=1, high=MAX_STEPS, resume_may_change=True)
    eval_episodes: int = setting(10, "episodes per evaluation", low=1, high=1000, resume_may_change=True)
    checkpoint_every: int = setting(50_000, "checkpoint the whole run every this many env steps", low=1, high=MAX_STEPS, resume_may_change=True)
    policy: str = setting("target", "the network evaluated and kept: target (the actor's Polyak average; docs/algorithm.md), actor (the online one) or average", choices=POLICY_NETWORKS)
    evaluate_other: bool = setting(True, "also evaluate the networks policy does not name on the same episodes (<name>_* columns)")
    average_tau: float = setting(0.0, "Polyak rate of a slower average of the actor, updated with the target (0: none); never feeds training", low=0.0, high=1.0, resume_may_change=True)

    def check(self) -> None:
        if vars(self)["policy"] == "average" and vars(self)["average_tau"] == 0.0:
            raise LwailError("train.policy=average needs train.average_tau > 0 (e.g. 0.001)")


@dataclass(frozen=True)
class CriticConfig(Validated):
    """The discriminator f and its loss; fixed at warm-up, inherited by `imitate`."""

    hidden: tuple[int, ...] = setting((64, 64), "hidden widths of f (ReLU)", low=1, high=4096)
    lr: float = setting(1e-3, "Adam learning rate of f (warm-up and online updates)", low=1e-7, high=1.0)
    gp_weight: float = setting(10.0, "weight λ of the WGAN-GP gradient penalty", low=0.0, high=1e4)
    tanh: bool = setting(True, "loss on tanh f, as the authors' code (false: the paper's plain dual); the reward stays σ(−f)")
    standardize: bool = setting(False, "standardise each input of f by its mean and spread over data set I's pairs, so the gradient penalty acts in those units (issue 40's screen)")


@dataclass(frozen=True)
class EnvConfig(Validated):
    """How each episode of the environment starts (every stage that plays episodes has one)."""

    start_noise: float = setting(0.0, "std of Gaussian noise added to each episode's initial state, seeded (PointMaze tasks; the paper's navigation table)", low=0.0, high=10.0)


# ------------------------------------------------------------------------------ one config per stage
@dataclass(frozen=True)
class CollectConfig(Validated):
    env: EnvConfig = section(EnvConfig, "the environment's start")
    transitions: int = setting(10_000, "uniformly random policy transitions to collect", low=1, high=MAX_BUFFER)


@dataclass(frozen=True)
class RecordConfig(Validated):
    env: EnvConfig = section(EnvConfig, "the environment's start")
    episodes: int = setting(10, "episodes to record from the policy", low=1, high=10_000)


@dataclass(frozen=True)
class ExpertConfig(Validated):
    env: EnvConfig = section(EnvConfig, "the environment's start (training and evaluation episodes)")
    td3: TD3Config = section(TD3Config, "TD3 settings")
    train: TrainConfig = section(TrainConfig, "run schedule")


@dataclass(frozen=True)
class ICVFConfig(Validated):
    steps: int = setting(10_000, "gradient steps (the authors train 200k; see docs/algorithm.md)", low=1, high=MAX_STEPS)
    batch_size: int = setting(256, "(s, s', s+, z) tuples per gradient step", low=1, high=65_536)
    hidden: tuple[int, ...] = setting((256,), "hidden widths of φ, ψ and T before the embedding layer", low=1, high=4096)
    embedding_dim: int = setting(256, "dimension of φ(s)", low=1, high=4096)
    layer_norm: str = setting(
        "after", "LayerNorm in φ, ψ, T: after each GELU (the JAX ICVF's LayerNormMLP; the default since 0.3, chosen by issue "
        "40's screen), none (the authors' PyTorch ICVF; the default in 0.2) or before it (the default in 0.1); docs/algorithm.md", choices=LAYER_NORMS, aliases={True: "before", False: "none", "true": "before", "false": "none"})
    ensemble: int = setting(2, "independent value functions (φ is taken from the first)", low=1, high=64)
    lr: float = setting(3e-4, "Adam learning rate", low=1e-7, high=1.0)
    gamma: float = setting(0.99, "discount of the intention-conditioned values", low=0.0, below=1.0)
    tau: float = setting(0.005, "Polyak rate of the target network", low=0.0, high=1.0)
    expectile: float = setting(0.9, "expectile of the value regression", low=0.0, high=1.0)
    p_goal_current: float = setting(0.2, "goal = the current state with this probability", low=0.0, high=1.0)
    p_goal_trajectory: float = setting(0.5, "goal = a later state of the same trajectory (else a random dataset state)", low=0.0, high=1.0)
    p_outcome_is_goal: float = setting(0.5, "outcome s+ = the goal z with this probability (else drawn anew)", low=0.0, high=1.0)
    holdout_fraction: float = setting(0.1, "episodes held out of training for the quality probe", low=0.0, below=1.0)
    log_every: int = setting(500, "log the loss and probe every this many steps", low=1, high=MAX_STEPS, resume_may_change=True)
    checkpoint_every: int = setting(5_000, "checkpoint the pre-training every this many steps (resume: --resume)", low=1, high=MAX_STEPS, resume_may_change=True)

    def check(self) -> None:
        trajectory_goals = vars(self)["p_goal_current"] + vars(self)["p_goal_trajectory"]
        if trajectory_goals > 1.0 + 1e-9:
            raise LwailError(
                f"icvf.p_goal_current + icvf.p_goal_trajectory must be at most 1 (the rest are random goals), got {trajectory_goals:g}"
            )


@dataclass(frozen=True)
class ContrastiveConfig(Validated):
    """What the contrastive embeddings share (contrastive.py): φ shaped as ICVF's, a bilinear score, Adam."""

    steps: int = setting(10_000, "gradient steps (as ICVF's default)", low=1, high=MAX_STEPS)
    batch_size: int = setting(512, "anchors per gradient step; each one's negatives are the batch's other positives", low=2, high=65_536)
    hidden: tuple[int, ...] = setting((256,), "hidden widths of φ before the embedding layer (as ICVF's φ)", low=1, high=4096)
    embedding_dim: int = setting(256, "dimension of φ(s)", low=1, high=4096)
    layer_norm: str = setting("after", "LayerNorm in φ: after each GELU, none or before it (as icvf.layer_norm)", choices=LAYER_NORMS)
    lr: float = setting(1e-3, "Adam learning rate of φ and W (PW-DICE's and CURL's)", low=1e-7, high=1.0)
    temperature: float = setting(1.0, "the bilinear score φ(a)ᵀWφ(p) is divided by this (1: the references' unscaled score)", low=1e-4, high=1e4)
    grad_clip: float = setting(1.0, "clip the gradient's norm at this (0: never)", low=0.0, high=1e6)
    holdout_fraction: float = setting(0.1, "episodes held out of training for the quality probe", low=0.0, below=1.0)
    log_every: int = setting(500, "log the loss and probe every this many steps", low=1, high=MAX_STEPS, resume_may_change=True)
    checkpoint_every: int = setting(5_000, "checkpoint the pre-training every this many steps (resume: --resume)", low=1, high=MAX_STEPS, resume_may_change=True)


@dataclass(frozen=True)
class InfoNCEConfig(ContrastiveConfig):
    """PW-DICE's embedding: the positive of s is its next state s'."""


@dataclass(frozen=True)
class CURLConfig(ContrastiveConfig):
    """CURL's embedding: the positive of s is another noisy copy of s, encoded by a slow (EMA) copy of φ."""

    grad_clip: float = setting(0.0, "clip the gradient's norm at this (0: never, as CURL)", low=0.0, high=1e6)
    tau: float = setting(0.05, "Polyak rate of the key encoder, the EMA of φ (CURL's encoder_tau)", low=0.0, high=1.0)
    noise: float = setting(0.1, "std of each copy's Gaussian noise, times each dimension's std over data set I", low=0.0, high=10.0)


EMBEDDING_KINDS = ("icvf", "identity", "infonce", "curl")  # one entry each in embeddings.EMBEDDINGS (tests/test_embeddings.py)


@dataclass(frozen=True)
class EmbedConfig(Validated):
    kind: str = setting("icvf", "icvf, identity (the paper's no-embedding ablation), infonce (PW-DICE's) or curl; docs/algorithm.md", choices=EMBEDDING_KINDS)
    icvf: ICVFConfig = section(ICVFConfig, "ICVF settings (the identity reads only holdout_fraction, for its probe)", used_when=("kind", ("icvf", "identity")))
    infonce: InfoNCEConfig = section(InfoNCEConfig, "InfoNCE settings, next state as the positive (kind infonce)", used_when=("kind", ("infonce",)))
    curl: CURLConfig = section(CURLConfig, "CURL settings, noisy copies as positives (kind curl)", used_when=("kind", ("curl",)))


@dataclass(frozen=True)
class WarmupConfig(Validated):
    critic: CriticConfig = section(CriticConfig, "the discriminator f")
    steps: int = setting(2_500, "full-batch warm-up steps of f", low=1, high=MAX_STEPS)
    transitions: int = setting(4_000, "random-policy (s, s') pairs f is warmed up against", low=1, high=MAX_BUFFER)
    expert_episodes: int = setting(1, "expert trajectories used", low=1, high=10_000)


@dataclass(frozen=True)
class GaifoConfig(Validated):
    """GAIfO's discriminator D on the pair features (methods/gaifo.py; trained on LWAIL's update_every schedule)."""

    hidden: tuple[int, ...] = setting((64, 64), "hidden widths of D (ReLU), as LWAIL's f", low=1, high=4096)
    lr: float = setting(1e-3, "Adam learning rate of D", low=1e-7, high=1.0)
    gp_weight: float = setting(10.0, "weight λ of the gradient penalty (‖∇D‖ − 1)² at expert-policy interpolates (DAC)", low=0.0, high=1e4)


@dataclass(frozen=True)
class PwilConfig(Validated):
    """PWIL's reward: greedy coupling with the expert's pairs within each episode (methods/pwil.py)."""

    alpha: float = setting(5.0, "reward scale α of α·exp(−β·T·c/√d) (the paper's 5)", low=0.0, high=1e4)
    beta: float = setting(5.0, "kernel width β (the paper's 5)", low=0.0, high=1e4)
    time_horizon: int = setting(1_000, "T: an episode's transitions share the expert's mass, 1/T each (the MuJoCo episode length)", low=1, high=MAX_STEPS)
    subsampling: int = setting(20, "keep every this many expert pairs as an atom (the paper's 20)", low=1, high=10_000)


@dataclass(frozen=True)
class InverseDynamicsSettings(Validated):
    """The inverse-dynamics model g of BCO and OPOLO (inverse_dynamics.py; OPOLO's idm.py), each method's own copy."""

    idm_hidden: tuple[int, ...] = setting((256, 256), "hidden widths of the inverse-dynamics model (tanh), the reference's", low=1, high=4096)
    idm_lr: float = setting(3e-4, "Adam learning rate of the inverse-dynamics model (the reference's)", low=1e-7, high=1.0)
    idm_weight_decay: float = setting(1e-3, "weight of the L2 term ½·Σw² over the model's weights and biases, added to its loss (the reference's)", low=0.0, high=10.0)


@dataclass(frozen=True)
class BcoConfig(InverseDynamicsSettings):
    """BCO(α): an inverse-dynamics model on data set I's actions, then behaviour cloning of the actions it infers for
    the demo, in rounds while the policy interacts (methods/bco.py; OPOLO's td3bco.py and idm.py)."""

    lr: float = setting(1e-3, "Adam learning rate of the cloned policy (the reference's MuJoCo learning_rate)", low=1e-7, high=1.0)
    batch_size: int = setting(100, "transitions per gradient step of the model, demo pairs per step of the policy (the reference's)", low=1, high=65_536)
    pretrain_steps: int = setting(1_000, "gradient steps of the model on data set I before the policy is first cloned (the reference's 100/α)", low=0, high=MAX_STEPS)
    interval: int = setting(1_000, "env steps between rounds of post-demonstration updates (the reference's train_freq)", low=1, high=MAX_STEPS)
    idm_steps: int = setting(100, "gradient steps of the model per round, on data set I and every transition played so far", low=0, high=100_000)
    bc_steps: int = setting(100, "gradient steps of the policy per round (and at the start) on the demo's inferred actions", low=0, high=100_000)
    exploration_noise: float = setting(0.1, "Gaussian noise on the policy's actions while it plays, times the action scale", low=0.0, high=10.0)


@dataclass(frozen=True)
class OpoloConfig(InverseDynamicsSettings):
    """OPOLO: TD3's critic and actor on OPOLO's objective, the reward GAIfO's, the policy pulled toward the actions an
    inverse-dynamics model infers for the demo (methods/opolo.py; OPOLO's td3opolo.py and its Hopper hyperparameters)."""

    alpha: float = setting(0.01, "weight α of the initial-value term 2α(1−γ)·E[min Q(s, π(s))], added to the critic's loss and subtracted from the actor's (the reference's Hopper value; 0.1 its default)", low=0.0, high=1e3)
    regularization: float = setting(0.01, "weight of the actor's mean squared error, in [-1, 1] units, to the actions g infers for demo pairs (the reference's Hopper pi_reg_coeff)", low=0.0, high=1e3)
    batch_size: int = setting(100, "transitions per gradient step of the inverse-dynamics model (the reference's)", low=1, high=65_536)
    pretrain_steps: int = setting(2_500, "gradient steps of the model on data set I before the first env step (the reference's 50 × 50 at its learning start)", low=0, high=MAX_STEPS)
    interval: int = setting(500, "env steps between rounds of the model's updates (the reference's train_idm_freq)", low=1, high=MAX_STEPS)
    idm_steps: int = setting(50, "gradient steps of the model per round, on data set I and every transition played so far (the reference's)", low=0, high=100_000)


@dataclass(frozen=True)
class DifoConfig(Validated):
    """DIFO's discriminator: a diffusion model of φ(s′) given φ(s) and a label, expert or agent, whose denoising errors
    under the two labels make D's logit (methods/difo.py; the reference's Walker2d settings, on LWAIL's update_every schedule)."""

    hidden: tuple[int, ...] = setting((256, 256, 256), "widths of the denoiser: an input layer, then blocks down these widths and back up with skip connections (the reference's num_units)", low=1, high=4096)
    embedding: int = setting(32, "width of the embeddings of the noise step, the label and the state that scale and shift each block (the reference's Walker2d emb_dim; even)", low=4, high=4096)
    lr: float = setting(1e-4, "Adam learning rate of the denoiser (the reference's)", low=1e-7, high=1.0)
    bce_weight: float = setting(0.01, "weight of the cross-entropy of D's logit beside the expert-labelled denoising loss (the reference's Walker2d value; its default 1)", low=0.0, high=1e4)
    logit_scale: float = setting(10.0, "κ in D's logit κ·(agent-labelled − expert-labelled denoising error) (the reference's)", low=1e-6, high=1e6)
    diffusion_steps: int = setting(1_000, "noising steps T of the cosine schedule (the reference's DDPM squaredcos_cap_v2)", low=2, high=100_000)
    reward_t_low: int = setting(250, "the reward's noise step t is drawn from reward_t_low … reward_t_high − 1 (the reference's)", low=0, high=100_000)
    reward_t_high: int = setting(750, "see reward_t_low; at most diffusion_steps", low=1, high=100_000)

    def check(self) -> None:
        values = vars(self)
        if values["embedding"] % 2:
            raise LwailError(f"difo.embedding must be even (its noise-step code is sines and cosines), got {values['embedding']}")
        if not values["reward_t_low"] < values["reward_t_high"] <= values["diffusion_steps"]:
            raise LwailError(f"difo.reward_t_low < difo.reward_t_high <= difo.diffusion_steps must hold, got {values['reward_t_low']}, "
                             f"{values['reward_t_high']}, {values['diffusion_steps']}")


@dataclass(frozen=True)
class ImitationConfig(Validated):
    env: EnvConfig = section(EnvConfig, "the environment's start (training and evaluation episodes)")
    td3: TD3Config = section(TD3Config, "TD3 settings")
    train: TrainConfig = section(TrainConfig, "run schedule")
    method: str = setting("lwail", "the imitation method: lwail (σ(−f), needs --disc), gaifo, pwil or difo (TD3 on their reward), opolo (TD3 on OPOLO's objective with GAIfO's reward) or bco (its own loop) (docs/algorithm.md)", choices=METHODS)
    update_every: int = setting(4_000, "train f or D (and relabel the buffer) every this many env steps (lwail, gaifo, opolo, difo)", low=1, high=MAX_STEPS,
                                 used_when=("method", ADVERSARIAL))
    update_steps: int = setting(40, "full-batch steps of f or D per update (paper: 40, authors' code: 30)", low=0, high=100_000,
                                 used_when=("method", ADVERSARIAL))
    expert_episodes: int = setting(1, "expert trajectories to imitate", low=1, high=10_000)
    gaifo: GaifoConfig = section(GaifoConfig, "GAIfO's discriminator (methods gaifo and opolo)", used_when=("method", ("gaifo", "opolo")))
    pwil: PwilConfig = section(PwilConfig, "PWIL's reward (method pwil)", used_when=("method", ("pwil",)))
    bco: BcoConfig = section(BcoConfig, "BCO's inverse-dynamics model and cloned policy (method bco)", used_when=("method", ("bco",)),
                             since="0.4")
    opolo: OpoloConfig = section(OpoloConfig, "OPOLO's objective and inverse-dynamics model (method opolo)", used_when=("method", ("opolo",)),
                                 since="0.4")
    difo: DifoConfig = section(DifoConfig, "DIFO's diffusion discriminator (method difo)", used_when=("method", ("difo",)), since="0.4")


@dataclass(frozen=True)
class EvalConfig(Validated):
    env: EnvConfig = section(EnvConfig, "the environment's start")
    episodes: int = setting(10, "deterministic evaluation episodes", low=1, high=10_000)
    seed: int = setting(100, "seed of the first evaluation episode (the others count up)", low=0, high=2**31)


STAGES: dict[str, type] = {  # keyed by the command that takes the config
    "collect": CollectConfig,
    "expert-train": ExpertConfig,
    "expert-record": RecordConfig,
    "pretrain-icvf": EmbedConfig,
    "warmup-disc": WarmupConfig,
    "imitate": ImitationConfig,
    "eval": EvalConfig,
}

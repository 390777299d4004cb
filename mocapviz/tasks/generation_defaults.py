"""What the ``generate`` command and the generation benchmarks use unless told otherwise (no
torch import: ``mocapviz generate --help`` shows them at once). A :class:`~mocapviz.tasks.generate.Generator`'s
own defaults are the model's plain output: its own plan (pace "network") and temperature 1."""

# trained on every body at many sizes, with the root decoded from the past alone (root_without_z):
# chosen over ccnet_phase_lerp_scale on the validation seeds, whose standing types it pushed
# 0.25-0.30 m/s forward (docs/experiments.md, "Why the waving walked off", says what each costs)
GENERATION_MODEL = "ccnet_generate"

# "seed": without a path, hold the seed's pace (the speed of its last own plan c^d: for a seed cut from
# a file, its last second's; mocapviz.tasks.controls.FreeRunning says why). With the network's own
# plan fed back frame by frame, ccnet_phase_lerp's Bandai run test seed slowed to 0.27x the real
# runs' ground speed over seconds 30-60; held, 0.84x (docs/experiments.md)
PACE = "seed"
PACES = ("seed", "network")  # what Generator(pace=...) and --pace accept

# Sampling spread: chosen on the 9 validation seeds (pace "seed"), where the sampled waving shakes at
# 1 and 0.7 (jitter 4.7x and 3.2x the real clips' with ccnet_phase_lerp, 4.9x and 3.5x with
# ccnet_phase_lerp_scale: over the moving bar's 3) and not at 0.5 (2.3x, 2.7x)
SAMPLING_TEMPERATURE = 0.5

# where a latent model's z comes from after the seed (Generator(z_source=...), --z-source): "seed", the
# posterior's mean over the seed's own frames, kept the held-out HDM05 sneak leaning forward (+17.1
# degrees over seconds 30-60 of bench_generate_files, the seed +38.5) where the sneak type's prior
# mean z stood it up (+5.6); "type", that prior (docs/experiments.md, "Why a generated sneak stands up")
Z_SOURCE = "seed"
Z_SOURCES = ("seed", "type")

# z after the seed searched for the code that keeps the seed's posture (mocapviz.tasks.posture_search):
# Z_SEARCH candidates a round (0 or 1: the seed's z as read), each run Z_SEARCH_SECONDS with the mean
# output; round 1 draws around the seed's z with the type prior's spread times Z_SEARCH_SPREADS[0],
# round 2 around round 1's best at Z_SEARCH_SPREADS[1]. Why: with the seed's z alone the held-out HDM05
# jog on a Mixamo A-pose skeleton stood 1.07x the seed's root height (docs/experiments.md, "A search
# for the z that keeps the posture", says what each round bought)
Z_SEARCH = 32
Z_SEARCH_SECONDS = 8.0
Z_SEARCH_SPREADS = (2.0, 0.5)

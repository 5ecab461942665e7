# The calibration cases (generate_cases.py writes them, run_cases.py runs camlab on
# them). Plain data: no mrcal needed to list them.
#
# One dataset per entry, calibrated once per model in `models` (each is a case, named
# DATASET__MODEL; "truth" = the truth's own model string; "auto" = camlab's selection).
# lens/hfov/imager: the truth. board COLSxROWS inner corners, spacing_m. noise_px: Gaussian
# sigma per coordinate at level 0. levels: mrgingham-style level column (0/1/2 at
# 70/20/10%). views. span: board width over imager width at the nominal distance.
# spread: board centres' offsets as a share of the half-field at that distance. tilt_deg:
# uniform rotation-vector noise about the board's x and y (roll 20 deg). which: mrcal's
# visibility rule ("full": every corner on the imager, "half": more than half). face:
# "axis" (boards' nominal normal along the optical axis, mrcal's convention) or "los"
# (each board turned to face the line of sight to its centre). quick: the models run by
# the ctest subset.

BASE = dict(noise_px=0.3, levels=False, views=40, span=0.45, spread=1.0, tilt_deg=35.0,
            which="full", outliers=0.0, face="axis", level_column=True, quick=[],
            distance_jitter=0.3, empty_images=0)

CASES = [
    # Lens models, fields, imagers, boards, noise, views.
    dict(name="o4_narrow30_640x480_10x10_40v", lens="opencv4", hfov=30, imager=(640, 480), board=(10, 10),
         spacing=0.05, levels=True, models=["LENSMODEL_OPENCV4", "auto"], quick=["auto"]),
    dict(name="o5_normal70_1280x800_14x10_40v", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, noise_px=0.2, which="half",
         models=["LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8", "auto"], quick=["LENSMODEL_OPENCV5", "auto"]),
    dict(name="o8_wide115_1280x800_14x10_20v", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, which="half", views=20, models=["LENSMODEL_OPENCV8", "auto"],
         quick=["LENSMODEL_OPENCV8"]),
    dict(name="o8_wide115_1280x800_14x10_100v", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, noise_px=0.1, views=100, which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="o8_wide110_4000x3000_10x10_100v", lens="opencv8", hfov=110, imager=(4000, 3000), board=(10, 10),
         spacing=0.1, noise_px=1.0, levels=True, views=100, which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="o8_wide100_640x480_10x10_10v", lens="opencv8", hfov=100, imager=(640, 480), board=(10, 10),
         spacing=0.02, noise_px=0.5, levels=True, views=10, which="half", models=["LENSMODEL_OPENCV8", "auto"],
         quick=["LENSMODEL_OPENCV8"]),
    dict(name="o5_normal65_6000x4000_7x5_10v", lens="opencv5", hfov=65, imager=(6000, 4000), board=(7, 5),
         spacing=0.1, noise_px=0.5, views=10, models=["LENSMODEL_OPENCV5", "auto"]),
    dict(name="o4_normal80_1920x1080_nolevel_20v", lens="opencv4", hfov=80, imager=(1920, 1080), board=(14, 10),
         spacing=0.03, noise_px=0.5, views=20, level_column=False, empty_images=3,
         models=["LENSMODEL_OPENCV4", "auto"]),
    dict(name="splined_wide120_1280x800_40v", lens="splined", hfov=120, imager=(1280, 800), board=(14, 10),
         spacing=0.04, which="half", models=["truth", "LENSMODEL_SPLINED_STEREOGRAPHIC", "auto"]),
    dict(name="o5_portrait55_3000x4000_14x10_30v", lens="opencv5", hfov=55, imager=(3000, 4000), board=(14, 10),
         spacing=0.05, noise_px=0.5, levels=True, views=30, which="half", models=["LENSMODEL_OPENCV5", "auto"]),
    # Hard cases.
    dict(name="hard_fisheye150_splined_1280x1024", lens="splined", hfov=150, imager=(1280, 1024), board=(14, 10),
         spacing=0.04, views=40, which="half", span=0.7,
         models=["truth", "LENSMODEL_SPLINED_STEREOGRAPHIC", "auto"]),
    dict(name="hard_views3_o5_1280x800", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=3, models=["LENSMODEL_OPENCV5", "auto"], quick=["LENSMODEL_OPENCV5"]),
    dict(name="hard_views5_o8_wide", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=5, which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="hard_views5_o4_narrow", lens="opencv4", hfov=30, imager=(640, 480), board=(10, 10),
         spacing=0.05, views=5, levels=True, models=["LENSMODEL_OPENCV4", "auto"]),
    dict(name="hard_outliers2pct_o8_wide", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, outliers=0.02, which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="hard_outliers2pct_o5_20v", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, outliers=0.02, views=20, models=["LENSMODEL_OPENCV5", "auto"],
         quick=["LENSMODEL_OPENCV5"]),
    dict(name="hard_fronto_imageplane_o4_60", lens="opencv4", hfov=60, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=20, tilt_deg=2.0, models=["LENSMODEL_OPENCV4", "auto"], quick=["LENSMODEL_OPENCV4"]),
    dict(name="hard_fronto_los_o5_70", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=20, tilt_deg=3.0, face="los", models=["LENSMODEL_OPENCV5", "auto"]),
    dict(name="hard_fronto_los_o8_wide", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=20, tilt_deg=3.0, face="los", which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="hard_centre_only_o8_wide", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=30, spread=0.12, span=0.3, models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="hard_centre_only_o5", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=30, spread=0.12, span=0.3, models=["LENSMODEL_OPENCV5", "auto"],
         quick=["LENSMODEL_OPENCV5"]),
    dict(name="hard_far_boards_o5", lens="opencv5", hfov=70, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=40, span=0.12, models=["LENSMODEL_OPENCV5", "auto"], quick=["LENSMODEL_OPENCV5"]),
    dict(name="hard_far_boards_o4_4000x3000", lens="opencv4", hfov=60, imager=(4000, 3000), board=(10, 10),
         spacing=0.1, views=40, span=0.1, noise_px=0.5, levels=True, models=["LENSMODEL_OPENCV4", "auto"]),
    dict(name="hard_long_focal_5xdiag_o4", lens="opencv4_long", focal_over_diag=5.0, imager=(1280, 800),
         board=(14, 10), spacing=0.04, views=30, tilt_deg=45.0, models=["LENSMODEL_OPENCV4", "auto"]),
    dict(name="hard_partial_heavy_o8_wide", lens="opencv8", hfov=115, imager=(1280, 800), board=(14, 10),
         spacing=0.04, views=40, span=0.9, spread=1.2, which="half", models=["LENSMODEL_OPENCV8", "auto"]),
    dict(name="hard_noise1px_10v_o4_640x480", lens="opencv4", hfov=60, imager=(640, 480), board=(10, 10),
         spacing=0.05, noise_px=1.0, views=10, models=["LENSMODEL_OPENCV4", "auto"]),
]


def model_tag(model):
    return model.replace("LENSMODEL_", "").lower() if model not in ("auto", "truth") else model


def case_list(subset="all", only=()):
    """(dataset spec, model, case name) of every case, in order; `only` filters by case
    or dataset name."""
    out = []
    for spec in CASES:
        for model in spec["models"]:
            name = spec["name"] + "__" + model_tag(model)
            if subset == "quick" and model not in spec.get("quick", []):
                continue
            if only and name not in only and spec["name"] not in only:
                continue
            out.append((spec, model, name))
    return out

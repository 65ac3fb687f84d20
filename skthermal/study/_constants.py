"""Settings of the Machine B study and the papers' figures it is compared with."""

TARGET = "disp_y_um"
TRAIN_TEST = "IV"
TEST_RUNS = ("I", "II", "III", "V", "VI")
# The thesis sampled Machine B about every 10 s (001: "a sixty minute test
# (350 samples)").
DEFAULT_SAMPLE_PERIOD_S = 10.0
QUICK_SAMPLE_PERIOD_S = 120.0


# 001 Tables 5-7 and 5-8 (also 000 Tables 6-7): R, RMSE (µm), NSE, residual
# band (±µm) of the models trained on Test IV, per test.
PAPER = {
    ("I", "anfis-grid"): (0.96, 1.53, 0.92, 3.0),
    ("I", "anfis-fcm"): (0.99, 1.23, 0.94, 2.0),
    ("II", "anfis-grid"): (0.99, 2.72, 0.96, 4.0),
    ("II", "anfis-fcm"): (0.99, 0.57, 0.99, 2.0),
    ("III", "anfis-grid"): (0.98, 2.78, 0.95, 5.0),
    ("III", "anfis-fcm"): (0.99, 1.06, 0.98, 2.0),
    ("V", "anfis-grid"): (0.97, 3.98, 0.95, 8.0),
    ("V", "anfis-fcm"): (0.99, 2.78, 0.97, 4.0),
    ("VI", "anfis-grid"): (0.98, 3.88, 0.95, 7.0),
    ("VI", "anfis-fcm"): (0.99, 2.78, 0.97, 5.0),
}
PAPER_RULES = {"anfis-fcm": 3, "anfis-grid": 243}
PAPER_SENSORS = ("T18_C", "T55_C", "T63_C", "T68_C", "T71_C")

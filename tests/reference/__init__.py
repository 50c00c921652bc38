"""Independent reference implementations (oracles) used only by the tests."""

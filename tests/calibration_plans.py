"""Small calibration plans shared by tests."""

#: one horizontal ball-bar circle on Felix: a valid measurement plan whose readings identify only 14 of the 36
#: parameters a ball-bar measurement can (the rank check of calibrate identify/report refuses it)
ONE_CIRCLE_PLAN = """[plan]
name = "one circle"
instrument = "ballbar"
[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
target = ["0 mm", "0 mm", "0 mm"]
bar_length = "300 mm"
measuring_range = "15 mm"
[[paths]]
kind = "circle"
label = "XY circle at z=150 mm"
plane = "XY"
centre = ["0 mm", "0 mm", "150 mm"]
radius = "259.808 mm"
points = 72
"""

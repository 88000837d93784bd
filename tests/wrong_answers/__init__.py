"""A plausible wrong answer for every exercise, kept out of the lessons.

``lesson_NN.py`` holds ``WRONG = {exercise number: source code}`` for lesson NN. Each wrong
answer is a mistake a student could make (an off-by-one window, the wrong axis, a typed
value instead of a computed one, a config left out), not the stub: it runs without error
and defines the names the check reads, and the check must then fail with an AssertionError.
``tests/test_lessons.py`` runs each lesson once with, before each exercise's solution, the
student copy's stub and this wrong answer, each followed by a copy of the check.
"""

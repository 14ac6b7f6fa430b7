"""A user study the station runs itself (issue #34): the study file, the order of conditions, questionnaire scores."""

"""Tests of s3o_drake.execution."""

"""The exception tree: an argument's error said with another name, and pickled whole."""

import pickle

from vptoolkit.errors import ArgumentError, InputError


def test_an_argument_error_names_its_argument_wherever_the_template_does() -> None:
    error = ArgumentError("{argument}: {'x'} is no size; give {argument} as 200KB", "shard_size")
    assert isinstance(error, InputError)
    assert str(error) == "shard_size: {'x'} is no size; give shard_size as 200KB"
    renamed = error.named("--shard-size")
    assert type(renamed) is ArgumentError and renamed.argument == "--shard-size"
    assert str(renamed) == "--shard-size: {'x'} is no size; give --shard-size as 200KB"
    again = pickle.loads(pickle.dumps(error))
    assert str(again) == str(error) and again.template == error.template

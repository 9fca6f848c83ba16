# The talking-face model: viseme images + the chosen flow database + a manifest.


rule model:
    input:
        visemes=rules.visemes.output.visemes,
        images=rules.visemes.output.images,
        flows=f"{FLOWS}/{config['flow']['method']}/{config['flow']['strategy']}",
    output:
        directory(MODEL),
    log:
        f"results/logs/model/{FACE}.log",
    conda:
        "../envs/miketalk.yaml"
    params:
        spec=method_json(config["flow"]["method"]),
        strategy=config["flow"]["strategy"],
    script:
        "../scripts/model.py"
